#include "hisfm/verify/context_disambiguator.h"

#include <algorithm>
#include <cmath>
#include <functional>

#include "hisfm/util/error.h"
#include "hisfm/util/logging.h"
#include "hisfm/util/timer.h"

namespace hisfm {

void DisambiguatorOptions::Check() const {
  HISFM_CHECK_OPTION(grid_cells,
                     grid_cells >= 2 && grid_cells <= 100, "in [2, 100]");
  HISFM_CHECK_OPTION(num_reference_pairs, num_reference_pairs >= 1, ">= 1");
  HISFM_CHECK_OPTION(min_relative_coverage,
                     min_relative_coverage > 0 && min_relative_coverage <= 1,
                     "in (0, 1]");
  HISFM_CHECK_OPTION(min_distinctive_ratio,
                     min_distinctive_ratio >= 0 && min_distinctive_ratio <= 1,
                     "in [0, 1]");
  HISFM_CHECK_OPTION(distinctive_significance,
                     distinctive_significance > 0 &&
                     distinctive_significance <= 1,
                     "in (0, 1]");
  HISFM_CHECK_OPTION(max_scan_memory_mb, max_scan_memory_mb >= 0, ">= 0");
}

namespace {

const DisambiguatorOptions& CheckedOptions(const DisambiguatorOptions& o) {
  o.Check();
  return o;
}

const VerifierContext& CheckedContext(const VerifierContext& context) {
  ThrowUnless(context.database != nullptr && context.graph != nullptr &&
                  context.communities != nullptr,
              "the builtin verifier needs the database, view graph and "
              "communities");
  return context;
}

}  // namespace

ContextDisambiguator::ContextDisambiguator(const Database& database,
                                           const ViewGraph& graph,
                                           const Communities& communities,
                                           const DisambiguatorOptions& options)
    : database_(database),
      graph_(graph),
      communities_(communities),
      options_(CheckedOptions(options)),
      grid_(database, options.grid_cells),
      read_scope_(database) {}

ContextDisambiguator::ContextDisambiguator(const VerifierContext& context,
                                           const DisambiguatorOptions& options)
    // (Each argument checks the whole context: their order of evaluation is
    // unspecified.)
    : ContextDisambiguator(*CheckedContext(context).database,
                           *CheckedContext(context).graph,
                           *CheckedContext(context).communities, options) {}

double ContextDisambiguator::ReferenceCells(ImageId image_id) {
  ImageCache& c = cache_[image_id];
  if (c.reference_done) return c.reference_cells;
  c.reference_done = true;
  // The image's strongest intra-community pairs: the trusted neighbours.
  std::vector<std::pair<uint32_t, ImageId>> trusted;
  if (graph_.HasImage(image_id) && communities_.community_of.count(image_id)) {
    const CommunityId own = communities_.Of(image_id);
    for (size_t e : graph_.IncidentEdges(graph_.IndexOf(image_id))) {
      const ImageId other = graph_.OtherEnd(e, image_id);
      auto it = communities_.community_of.find(other);
      if (it == communities_.community_of.end() || it->second != own) continue;
      trusted.push_back({graph_.Edges()[e].weight, other});
    }
  }
  std::sort(trusted.begin(), trusted.end(), [](const auto& a, const auto& b) {
    return a.first > b.first || (a.first == b.first && a.second < b.second);
  });
  if (trusted.size() > static_cast<size_t>(options_.num_reference_pairs)) {
    trusted.resize(options_.num_reference_pairs);
  }
  int best = 0;
  for (const auto& t : trusted) {
    const std::vector<FeatureMatch> inliers =
        database_.ReadInlierMatches(image_id, t.second);
    best = std::max(best, grid_.CoveredCells(image_id, inliers,
                                             image_id < t.second));
  }
  // (References into an unordered_map stay valid when it grows.)
  c.has_reference = best > 0;
  c.reference_cells = best;
  return c.reference_cells;
}

double ContextDisambiguator::SceneReferenceFraction() {
  if (scene_reference_fraction_ >= 0) return scene_reference_fraction_;
  std::vector<double> fractions;
  for (ImageId id : graph_.Images()) {
    const double ref = ReferenceCells(id);
    const int textured = grid_.TexturedCells(id);
    if (cache_.at(id).has_reference && textured > 0) {
      fractions.push_back(ref / textured);
    }
  }
  if (fractions.empty()) {
    scene_reference_fraction_ = 1.0;
  } else {
    std::nth_element(fractions.begin(),
                     fractions.begin() + fractions.size() / 2,
                     fractions.end());
    scene_reference_fraction_ = fractions[fractions.size() / 2];
  }
  return scene_reference_fraction_;
}

const TrackConsistency& ContextDisambiguator::Tracks() {
  if (!tracks_ && records_done_) {
    tracks_ = std::make_unique<TrackConsistency>(database_, graph_);
  } else if (!tracks_) {
    // The read that joins the tracks also records the bridges.
    RecordDuring([&](const PairObserver& on_read, const PairObserver& on_join) {
      tracks_ = std::make_unique<TrackConsistency>(database_, graph_, on_read,
                                                   on_join);
    });
  }
  return *tracks_;
}

void ContextDisambiguator::RecordBridges() {
  if (records_done_) return;
  if (options_.min_distinctive_ratio > 0) {
    Tracks();
  } else {
    // Without the distinctive cue there are no tracks to join: a read of the
    // bridges alone.
    RecordDuring([&](const PairObserver& on_read, const PairObserver& on_join) {
      database_.ForEachInlierMatches(Bridges(), on_join, on_read);
    });
  }
}

void ContextDisambiguator::RecordDuring(
    const std::function<void(const PairObserver&, const PairObserver&)>&
        read) {
  records_done_ = true;
  const Timer timer;
  const std::vector<ImagePair>& bridges = Bridges();
  for (const ImagePair& p : bridges) {
    grid_.Load(p.image_id1);
    grid_.Load(p.image_id2);
  }
  const std::unordered_map<ImageId, size_t> num_keypoints =
      database_.ReadNumKeypoints();
  records_.assign(bridges.size(), ScanRecord());
  const double max_bytes = options_.max_scan_memory_mb * (1 << 20);
  const size_t records_bytes = records_.size() * sizeof(ScanRecord);
  // Both observers see the reads in pair-id order, as the bridges are
  // listed; each walks the list with its own cursor (advanced to `pair`:
  // true if `pair` is a bridge, then at its index) and writes its own fields
  // of a record.
  auto seek = [&](size_t* cursor, const ImagePair& pair) {
    while (*cursor < bridges.size() && bridges[*cursor] < pair) ++*cursor;
    return *cursor < bridges.size() && bridges[*cursor] == pair;
  };
  size_t read_next = 0;
  CoverageGrid::Scratch scratch;
  const PairObserver count_cells = [&](const ImagePair& pair,
                                       FeatureMatchSpan inliers) {
    if (!seek(&read_next, pair)) return;
    ScanRecord& r = records_[read_next];
    r.cells1 = grid_.CoveredCells(pair.image_id1, inliers, true, &scratch);
    r.cells2 = grid_.CoveredCells(pair.image_id2, inliers, false, &scratch);
  };
  size_t join_next = 0;
  bool full = false;
  const PairObserver keep_keypoints = [&](const ImagePair& pair,
                                          FeatureMatchSpan inliers) {
    if (full || !seek(&join_next, pair)) return;
    auto it = num_keypoints.find(pair.image_id1);
    const size_t n1 = it == num_keypoints.end() ? 0 : it->second;
    if (records_bytes +
            bridge_keypoints_.BytesAfterAdding(n1, inliers.size()) >
        max_bytes) {
      full = true;
      return;
    }
    ScanRecord& r = records_[join_next];
    r.num_inliers = static_cast<uint32_t>(inliers.size());
    r.keypoints = bridge_keypoints_.Add(n1, inliers);
    r.recorded = true;
  };
  read(count_cells, keep_keypoints);
  size_t num_recorded = 0;
  for (const ScanRecord& r : records_) num_recorded += r.recorded;
  HISFM_LOG_DEBUG(
      "builtin verifier: read {} pairs, recorded {} of {} bridges ({} MB; "
      "{:.2f} s)",
      tracks_ ? graph_.NumEdges() : bridges.size(), num_recorded,
      bridges.size(), (bridge_keypoints_.Bytes() + records_bytes) >> 20,
      timer.ElapsedSeconds());
}

ContextDisambiguator::~ContextDisambiguator() = default;

void ContextDisambiguator::Prepare(const ImagePair& pair) {
  for (const ImageId id : {pair.image_id1, pair.image_id2}) {
    grid_.Load(id);
    const double ref = ReferenceCells(id);
    ImageCache& c = cache_.at(id);
    if (c.bridge_reference > 0) continue;
    // An image without a trusted neighbour: the scene's typical fraction of
    // its textured cells.
    c.bridge_reference =
        c.has_reference
            ? ref
            : std::max(1.0, SceneReferenceFraction() * grid_.TexturedCells(id));
  }
  if (options_.min_distinctive_ratio > 0) Tracks();
}

BridgeEvidence ContextDisambiguator::Evaluate(const ImagePair& pair) {
  Prepare(pair);
  // Oriented as stored: the smaller id first.
  const ImagePair p(pair.image_id1, pair.image_id2);
  return MeasureInliers(pair,
                        database_.ReadInlierMatches(p.image_id1, p.image_id2));
}

BridgeEvidence ContextDisambiguator::MeasureInliers(const ImagePair& pair,
                                                    FeatureMatchSpan inliers) {
  const ImagePair p(pair.image_id1, pair.image_id2);
  std::optional<DistinctiveSupport> support;
  if (options_.min_distinctive_ratio > 0 && !inliers.empty()) {
    support = tracks_->Support(p, inliers);
  }
  return Combine(
      pair, static_cast<uint32_t>(inliers.size()),
      grid_.CoveredCells(p.image_id1, inliers, true, &scratch_),
      grid_.CoveredCells(p.image_id2, inliers, false, &scratch_), support);
}

BridgeEvidence ContextDisambiguator::MeasureRecord(const ImagePair& pair,
                                                   const ScanRecord& r) {
  const ImagePair p(pair.image_id1, pair.image_id2);
  std::optional<DistinctiveSupport> support;
  if (options_.min_distinctive_ratio > 0 && r.num_inliers > 0) {
    support = tracks_->Support(p, r.num_inliers, bridge_keypoints_,
                               r.keypoints);
  }
  return Combine(pair, r.num_inliers, r.cells1, r.cells2, support);
}

BridgeEvidence ContextDisambiguator::Combine(
    const ImagePair& pair, uint32_t num_inliers, int cells1, int cells2,
    const std::optional<DistinctiveSupport>& support) const {
  BridgeEvidence ev;
  ev.pair = pair;
  const ImagePair p(pair.image_id1, pair.image_id2);
  ev.num_inliers = num_inliers;
  ev.cells1 = cells1;
  ev.cells2 = cells2;
  ev.reference1 = cache_.at(p.image_id1).bridge_reference;
  ev.reference2 = cache_.at(p.image_id2).bridge_reference;
  ev.relative1 = std::min(1.0, ev.cells1 / ev.reference1);
  ev.relative2 = std::min(1.0, ev.cells2 / ev.reference2);
  ev.relative = std::min(ev.relative1, ev.relative2);
  ev.coverage_score =
      std::min(1.0, ev.relative / (2.0 * options_.min_relative_coverage));
  if (support) {
    const DistinctiveSupport& s = *support;
    ev.num_distinctive = s.num_distinctive;
    ev.image_distinctive_fraction = s.image_fraction;
    ev.distinctive_p_value = s.p_value;
    if (s.p_value < options_.distinctive_significance) {
      ev.distinctive_ratio = s.ratio;
      ev.distinctive_score =
          std::min(1.0, s.ratio / (2.0 * options_.min_distinctive_ratio));
    }
  }
  ev.score = std::min(ev.coverage_score, ev.distinctive_score);
  return ev;
}

const std::vector<ImagePair>& ContextDisambiguator::Bridges() {
  if (!bridges_) {
    // The graph's edges, and so the bridges, are in pair-id order.
    bridges_.emplace();
    for (const ViewGraphEdge& e : graph_.Edges()) {
      if (communities_.Of(e.pair.image_id1) !=
          communities_.Of(e.pair.image_id2)) {
        bridges_->push_back(e.pair);
      }
    }
  }
  return *bridges_;
}

size_t ContextDisambiguator::BridgeIndex(const ImagePair& pair) {
  const std::vector<ImagePair>& bridges = Bridges();
  const ImagePair p(pair.image_id1, pair.image_id2);
  auto it = std::lower_bound(bridges.begin(), bridges.end(), p);
  return it != bridges.end() && *it == p ? it - bridges.begin()
                                         : bridges.size();
}

std::vector<double> ContextDisambiguator::Score(
    const std::vector<ImagePair>& pairs) {
  std::vector<double> scores;
  scores.reserve(pairs.size());
  for (const ImagePair& pair : pairs) {
    Prepare(pair);
    RecordBridges();
    const size_t k = BridgeIndex(pair);
    if (k < records_.size() && records_[k].recorded) {
      ++num_scored_from_scan_;
      scores.push_back(MeasureRecord(pair, records_[k]).score);
    } else {
      ++num_scored_by_reading_;
      scores.push_back(Evaluate(pair).score);
    }
  }
  return scores;
}

}  // namespace hisfm
