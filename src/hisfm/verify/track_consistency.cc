#include "hisfm/verify/track_consistency.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "hisfm/graph/union_find.h"
#include "hisfm/util/error.h"

namespace hisfm {

TrackConsistency::TrackConsistency(
    const Database& database, const ViewGraph& graph,
    const std::function<void(const ImagePair&, FeatureMatchSpan)>& on_read,
    const std::function<void(const ImagePair&, FeatureMatchSpan)>& on_join) {
  // Keypoints of all graph images, indexed densely.
  const std::unordered_map<ImageId, size_t> num_keypoints =
      database.ReadNumKeypoints();
  size_t total = 0;
  images_.reserve(graph.NumImages());
  for (ImageId id : graph.Images()) {
    ImageState s;
    s.offset = total;
    auto it = num_keypoints.find(id);
    s.num_keypoints = it == num_keypoints.end() ? 0 : it->second;
    total += s.num_keypoints;
    images_[id] = s;
  }
  state_.assign(total, kUnmatched);
  UnionFind tracks(total);
  size_t num_read = 0;
  database.ForEachInlierMatches(
      graph.Pairs(), [&](const ImagePair& pair,
                         FeatureMatchSpan inliers) {
        ++num_read;
        const ImageState& s1 = images_.at(pair.image_id1);
        const ImageState& s2 = images_.at(pair.image_id2);
        for (const FeatureMatch& m : inliers) {
          if (m.idx1 >= s1.num_keypoints || m.idx2 >= s2.num_keypoints) {
            continue;
          }
          const size_t a = s1.offset + m.idx1;
          const size_t b = s2.offset + m.idx2;
          state_[a] = state_[b] = kDistinctive;
          tracks.Union(a, b);
        }
        if (on_join) on_join(pair, inliers);
      },
      on_read);
  if (num_read != graph.NumEdges()) {
    throw Error(StrCat("track consistency: ", graph.NumEdges() - num_read,
                       " pair(s) of the view graph have no two-view geometry "
                       "in ", database.path()));
  }
  // A track is inconsistent if two of its keypoints belong to one image:
  // visiting the images one at a time, a track met twice during one image's
  // visit is inconsistent. Two linear passes, no sort.
  constexpr uint32_t kNotVisited = std::numeric_limits<uint32_t>::max();
  std::vector<uint32_t> last_visit(total, kNotVisited);  // By root.
  std::vector<char> inconsistent(total, 0);              // By root.
  uint32_t ordinal = 0;
  for (const auto& [id, s] : images_) {
    for (size_t k = s.offset; k < s.offset + s.num_keypoints; ++k) {
      if (state_[k] == kUnmatched) continue;
      const size_t r = tracks.Find(k);
      if (last_visit[r] == ordinal) inconsistent[r] = 1;
      last_visit[r] = ordinal;
    }
    ++ordinal;
  }
  for (size_t k = 0; k < total; ++k) {
    if (state_[k] != kUnmatched && inconsistent[tracks.Find(k)]) {
      state_[k] = kRepeated;
    }
  }
  size_t num_words = 0;
  for (auto& [id, s] : images_) {
    s.word_offset = num_words;
    num_words += (s.num_keypoints + 63) / 64;
  }
  distinctive_bits_.assign(num_words, 0);
  for (auto& [id, s] : images_) {
    for (size_t k = 0; k < s.num_keypoints; ++k) {
      const uint8_t st = state_[s.offset + k];
      s.num_matched += st != kUnmatched;
      s.num_distinctive += st == kDistinctive;
      if (st == kDistinctive) {
        distinctive_bits_[s.word_offset + k / 64] |= uint64_t{1} << (k % 64);
      }
    }
    num_matched_ += s.num_matched;
    num_repeated_ += s.num_matched - s.num_distinctive;
  }
}

uint8_t TrackConsistency::State(ImageId image_id, uint32_t idx) const {
  auto it = images_.find(image_id);
  if (it == images_.end() || idx >= it->second.num_keypoints) {
    return kUnmatched;
  }
  return state_[it->second.offset + idx];
}

TrackConsistency::ImageKeypoints TrackConsistency::KeypointsOf(
    ImageId image_id) const {
  ImageKeypoints out;
  auto it = images_.find(image_id);
  if (it != images_.end()) {
    out.states_ = state_.data() + it->second.offset;
    out.num_keypoints_ = it->second.num_keypoints;
  }
  return out;
}

bool TrackConsistency::IsMatched(ImageId image_id, uint32_t idx) const {
  return State(image_id, idx) != kUnmatched;
}

bool TrackConsistency::IsDistinctive(ImageId image_id, uint32_t idx) const {
  return State(image_id, idx) == kDistinctive;
}

double TrackConsistency::DistinctiveFraction(ImageId image_id) const {
  auto it = images_.find(image_id);
  if (it == images_.end() || it->second.num_matched == 0) return 0.0;
  return static_cast<double>(it->second.num_distinctive) /
         it->second.num_matched;
}

size_t TrackConsistency::NumMatched(ImageId image_id) const {
  auto it = images_.find(image_id);
  return it == images_.end() ? 0 : it->second.num_matched;
}

namespace {

// P(X <= k) for X ~ Poisson(lambda), summed in log space.
double PoissonCdf(uint32_t k, double lambda) {
  if (lambda <= 0) return 1.0;
  double log_term = -lambda;  // log P(X = 0)
  double sum = std::exp(log_term);
  for (uint32_t i = 1; i <= k; ++i) {
    log_term += std::log(lambda) - std::log(static_cast<double>(i));
    sum += std::exp(log_term);
  }
  return std::min(1.0, sum);
}

}  // namespace

DistinctiveSupport TrackConsistency::Support(
    const ImagePair& pair, FeatureMatchSpan inliers) const {
  uint32_t num_distinctive = 0;
  auto it = images_.find(pair.image_id1);
  if (it != images_.end()) {
    const uint8_t* state = state_.data() + it->second.offset;
    const size_t n = it->second.num_keypoints;
    for (const FeatureMatch& m : inliers) {
      num_distinctive += m.idx1 < n && state[m.idx1] == kDistinctive;
    }
  }
  return SupportFromCount(pair, static_cast<uint32_t>(inliers.size()),
                          num_distinctive);
}

DistinctiveSupport TrackConsistency::Support(const ImagePair& pair,
                                             uint32_t num_inliers,
                                             const KeypointMultisets& keypoints,
                                             size_t k) const {
  uint32_t num_distinctive = 0;
  auto it = images_.find(pair.image_id1);
  if (it != images_.end()) {
    num_distinctive = static_cast<uint32_t>(
        keypoints.CountIn(k, distinctive_bits_.data() + it->second.word_offset,
                          (it->second.num_keypoints + 63) / 64));
  }
  return SupportFromCount(pair, num_inliers, num_distinctive);
}

DistinctiveSupport TrackConsistency::SupportFromCount(
    const ImagePair& pair, uint32_t num_inliers,
    uint32_t num_distinctive) const {
  DistinctiveSupport s;
  s.num_inliers = num_inliers;
  s.num_distinctive = num_distinctive;
  s.image_fraction = std::min(DistinctiveFraction(pair.image_id1),
                              DistinctiveFraction(pair.image_id2));
  s.expected = s.image_fraction * s.num_inliers;
  if (s.expected > 0) {
    s.ratio = std::min(1.0, s.num_distinctive / s.expected);
    // Only shortfalls matter: the sum is needed below the mean alone.
    if (s.num_distinctive < s.expected) {
      s.p_value = PoissonCdf(s.num_distinctive, s.expected);
    }
  }
  return s;
}

double TrackConsistency::InconsistentFraction() const {
  return num_matched_ ? static_cast<double>(num_repeated_) / num_matched_
                      : 0.0;
}

}  // namespace hisfm
