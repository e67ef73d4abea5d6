#include "hisfm/graph/sequence_chain.h"

#include <algorithm>
#include <cmath>
#include <random>
#include <unordered_map>

#include "hisfm/graph/graph_segments.h"
#include "hisfm/util/error.h"
#include "hisfm/util/string_util.h"

namespace hisfm {

void SequenceOptions::Check() const {
  HISFM_CHECK_OPTION(mode, mode == "auto" || mode == "on" || mode == "off",
                     "auto, on or off");
  HISFM_CHECK_OPTION(min_consecutive_share,
                     min_consecutive_share >= 0.0 && min_consecutive_share <= 1.0,
                     "in [0, 1]");
  HISFM_CHECK_OPTION(min_z_score, std::isfinite(min_z_score), "finite");
  HISFM_CHECK_OPTION(num_permutations, num_permutations >= 10, ">= 10");
  HISFM_CHECK_OPTION(break_ratio, break_ratio >= 0.0 && break_ratio <= 1.0,
                     "in [0, 1]");
  HISFM_CHECK_OPTION(break_window, break_window >= 1, ">= 1");
}

namespace {

// Seed of the permutation test's shuffles (the test is deterministic).
constexpr uint32_t kPermutationSeed = 20261206;

// Inliers summed over the consecutive pairs of `order` (image ids).
double ConsecutiveWeight(const ViewGraph& graph,
                         const std::vector<ImageId>& order) {
  double sum = 0.0;
  for (size_t k = 0; k + 1 < order.size(); ++k) {
    sum += graph.Weight(order[k], order[k + 1]);
  }
  return sum;
}

double Median(std::vector<uint32_t> values) {
  const size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + mid, values.end());
  if (values.size() % 2 == 1) return values[mid];
  const uint32_t upper = values[mid];
  const uint32_t lower = *std::max_element(values.begin(), values.begin() + mid);
  return 0.5 * (lower + upper);
}

}  // namespace

SequenceChain FindSequenceChain(
    const ViewGraph& graph,
    const std::unordered_map<ImageId, std::string>& names,
    const SequenceOptions& options) {
  options.Check();
  SequenceChain chain;
  chain.order = graph.Images();
  for (const ImageId id : chain.order) {
    ThrowUnless(names.count(id) > 0,
                StrCat("sequence prior: image ", id, " has no name"));
  }
  std::sort(chain.order.begin(), chain.order.end(),
            [&](ImageId a, ImageId b) {
              const std::string& na = names.at(a);
              const std::string& nb = names.at(b);
              return na != nb ? na < nb : a < b;
            });
  const size_t n = chain.order.size();
  if (n < 2) return chain;

  std::vector<uint32_t> link_weights(n - 1);
  size_t num_verified = 0;
  for (size_t k = 0; k + 1 < n; ++k) {
    link_weights[k] = graph.Weight(chain.order[k], chain.order[k + 1]);
    if (link_weights[k] > 0) ++num_verified;
  }
  chain.consecutive_share = static_cast<double>(num_verified) / (n - 1);

  if (n >= 3) {
    const double observed = ConsecutiveWeight(graph, chain.order);
    std::mt19937 rng(kPermutationSeed);
    std::vector<ImageId> shuffled = chain.order;
    double sum = 0.0, sum_sq = 0.0;
    for (int p = 0; p < options.num_permutations; ++p) {
      std::shuffle(shuffled.begin(), shuffled.end(), rng);
      const double w = ConsecutiveWeight(graph, shuffled);
      sum += w;
      sum_sq += w * w;
    }
    const double mean = sum / options.num_permutations;
    const double var =
        std::max(0.0, sum_sq / options.num_permutations - mean * mean);
    // A complete graph of equal weights has no spread: any order is as good.
    chain.z_score = var > 0.0 ? (observed - mean) / std::sqrt(var) : 0.0;
  }

  chain.applies =
      options.mode == "on" ||
      (options.mode == "auto" &&
       chain.consecutive_share >= options.min_consecutive_share &&
       chain.z_score >= options.min_z_score);

  const size_t window = static_cast<size_t>(options.break_window);
  for (size_t k = 0; k + 1 < n; ++k) {
    const size_t lo = k >= window ? k - window : 0;
    const size_t hi = std::min(n - 1, k + window + 1);
    const double local = Median(std::vector<uint32_t>(
        link_weights.begin() + lo, link_weights.begin() + hi));
    if (link_weights[k] == 0 || link_weights[k] < options.break_ratio * local) {
      ++chain.num_breaks;
      continue;
    }
    chain.links.emplace_back(chain.order[k], chain.order[k + 1]);
  }
  std::sort(chain.links.begin(), chain.links.end());
  return chain;
}

std::vector<ImagePair> NearChainPairs(const SequenceChain& chain,
                                      const std::vector<ImagePair>& pairs,
                                      int window) {
  std::unordered_map<ImageId, size_t> place;
  for (size_t k = 0; k < chain.order.size(); ++k) place[chain.order[k]] = k;
  // breaks_before[k]: consecutive pairs before place k that are not links.
  std::vector<size_t> breaks_before(chain.order.size(), 0);
  for (size_t k = 1; k < chain.order.size(); ++k) {
    const bool link = std::binary_search(
        chain.links.begin(), chain.links.end(),
        ImagePair(chain.order[k - 1], chain.order[k]));
    breaks_before[k] = breaks_before[k - 1] + (link ? 0 : 1);
  }
  std::vector<ImagePair> near;
  for (const ImagePair& pair : pairs) {
    const auto a = place.find(pair.image_id1);
    const auto b = place.find(pair.image_id2);
    if (a == place.end() || b == place.end()) continue;
    const size_t lo = std::min(a->second, b->second);
    const size_t hi = std::max(a->second, b->second);
    if (hi - lo <= static_cast<size_t>(std::max(window, 0)) &&
        breaks_before[hi] == breaks_before[lo]) {
      near.push_back(pair);
    }
  }
  return near;
}

std::vector<std::vector<ImagePair>> ChainSegments(const SequenceChain& chain,
                                                  size_t segment_images,
                                                  size_t overlap) {
  const size_t n = chain.order.size();
  if (segment_images == 0 || n <= segment_images) {
    if (chain.links.empty()) return {};
    return {chain.links};
  }
  const std::vector<std::pair<size_t, size_t>> spans =
      OverlappingSpans(n, segment_images, overlap);
  std::unordered_map<ImageId, size_t> place;
  for (size_t k = 0; k < n; ++k) place[chain.order[k]] = k;
  std::vector<std::vector<ImagePair>> segments(spans.size());
  for (const ImagePair& link : chain.links) {
    const auto a = place.find(link.image_id1);
    const auto b = place.find(link.image_id2);
    if (a == place.end() || b == place.end()) continue;
    const size_t lo = std::min(a->second, b->second);
    const size_t hi = std::max(a->second, b->second);
    for (size_t j = 0; j < spans.size(); ++j) {
      if (lo >= spans[j].first && hi < spans[j].second) {
        segments[j].push_back(link);
      }
    }
  }
  segments.erase(
      std::remove_if(segments.begin(), segments.end(),
                     [](const std::vector<ImagePair>& s) { return s.empty(); }),
      segments.end());
  return segments;
}

}  // namespace hisfm
