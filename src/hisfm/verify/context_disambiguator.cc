#include "hisfm/verify/context_disambiguator.h"

#include <algorithm>
#include <cmath>
#include <functional>

#include "hisfm/util/error.h"
#include "hisfm/util/logging.h"
#include "hisfm/util/parallel.h"
#include "hisfm/util/timer.h"

namespace hisfm {

void DisambiguatorOptions::Check() const {
  HISFM_CHECK_OPTION(grid_cells >= 2 && grid_cells <= 100);
  HISFM_CHECK_OPTION(num_reference_pairs >= 1);
  HISFM_CHECK_OPTION(min_relative_coverage > 0 && min_relative_coverage <= 1);
  HISFM_CHECK_OPTION(min_distinctive_ratio >= 0 && min_distinctive_ratio <= 1);
  HISFM_CHECK_OPTION(distinctive_significance > 0 &&
                     distinctive_significance <= 1);
  HISFM_CHECK_OPTION(num_threads >= 1 && num_threads <= 64);
  HISFM_CHECK_OPTION(bulk_after_fraction >= 0 && bulk_after_fraction <= 1);
  HISFM_CHECK_OPTION(bulk_min_bridges >= 1);
}

struct ContextDisambiguator::Worker {
  explicit Worker(const std::string& path) : database(path), scope(database) {}
  Database database;
  Database::ReadScope scope;
  CoverageGrid::Scratch scratch;
};

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
    : ContextDisambiguator(*CheckedContext(context).database, *context.graph,
                           *context.communities, options) {}

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
  if (!tracks_) {
    const Timer timer;
    tracks_ = std::make_unique<TrackConsistency>(database_, graph_);
    HISFM_LOG_DEBUG("builtin verifier: tracks of {} pairs ({:.2f} s)",
                    graph_.NumEdges(), timer.ElapsedSeconds());
  }
  return *tracks_;
}

ContextDisambiguator::~ContextDisambiguator() = default;

size_t ContextDisambiguator::PreferredBatchSize() const {
  return options_.num_threads > 1 ? 256 : 1;
}

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
  return Measure(database_, pair, &scratch_);
}

BridgeEvidence ContextDisambiguator::Measure(
    const Database& database, const ImagePair& pair,
    CoverageGrid::Scratch* scratch) const {
  // Oriented as stored: the smaller id first.
  const ImagePair p(pair.image_id1, pair.image_id2);
  return MeasureInliers(pair,
                        database.ReadInlierMatches(p.image_id1, p.image_id2),
                        scratch);
}

BridgeEvidence ContextDisambiguator::MeasureInliers(
    const ImagePair& pair, const std::vector<FeatureMatch>& inliers,
    CoverageGrid::Scratch* scratch) const {
  BridgeEvidence ev;
  ev.pair = pair;
  const ImagePair p(pair.image_id1, pair.image_id2);
  ev.num_inliers = static_cast<uint32_t>(inliers.size());
  ev.cells1 = grid_.CoveredCells(p.image_id1, inliers, true, scratch);
  ev.cells2 = grid_.CoveredCells(p.image_id2, inliers, false, scratch);
  ev.reference1 = cache_.at(p.image_id1).bridge_reference;
  ev.reference2 = cache_.at(p.image_id2).bridge_reference;
  ev.relative1 = std::min(1.0, ev.cells1 / ev.reference1);
  ev.relative2 = std::min(1.0, ev.cells2 / ev.reference2);
  ev.relative = std::min(ev.relative1, ev.relative2);
  ev.coverage_score =
      std::min(1.0, ev.relative / (2.0 * options_.min_relative_coverage));
  if (options_.min_distinctive_ratio > 0 && ev.num_inliers > 0) {
    const DistinctiveSupport s = tracks_->Support(p, inliers);
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

void ContextDisambiguator::MeasureAllBridges() {
  bulk_done_ = true;
  const Timer timer;
  const std::vector<ImagePair>& bridges = Bridges();
  for (const ImagePair& p : bridges) Prepare(p);
  // Thread w scans its own range of pair ids.
  std::vector<std::vector<std::pair<PairId, double>>> parts(
      std::min<size_t>(options_.num_threads,
                       std::max<size_t>(1, bridges.size())));
  RunOnThreads(parts.size(), [&](size_t w, const Database& database,
                                 CoverageGrid::Scratch* scratch) {
    const size_t begin = w * bridges.size() / parts.size();
    const size_t end = (w + 1) * bridges.size() / parts.size();
    database.ForEachInlierMatches(
        std::vector<ImagePair>(bridges.begin() + begin, bridges.begin() + end),
        [&](const ImagePair& pair, const std::vector<FeatureMatch>& inliers) {
          parts[w].push_back(
              {ImagePairToPairId(pair.image_id1, pair.image_id2),
               MeasureInliers(pair, inliers, scratch).score});
        });
  });
  bulk_scores_.clear();
  for (const auto& part : parts) {
    bulk_scores_.insert(bulk_scores_.end(), part.begin(), part.end());
  }
  // (In order already: the graph's edges are sorted by pair.)
  if (!std::is_sorted(bulk_scores_.begin(), bulk_scores_.end())) {
    std::sort(bulk_scores_.begin(), bulk_scores_.end());
  }
  HISFM_LOG_DEBUG("builtin verifier: measured all {} bridges at once "
                  "({:.2f} s)",
                  bridges.size(), timer.ElapsedSeconds());
}

void ContextDisambiguator::RunOnThreads(
    size_t num_threads,
    const std::function<void(size_t, const Database&, CoverageGrid::Scratch*)>&
        fn) {
  while (workers_.size() + 1 < num_threads) {
    workers_.push_back(std::make_unique<Worker>(database_.path()));
  }
  ParallelFor(num_threads, static_cast<int>(num_threads), [&](size_t w) {
    if (w == 0) {
      fn(0, database_, &scratch_);
    } else {
      fn(w, workers_[w - 1]->database, &workers_[w - 1]->scratch);
    }
  });
}

std::vector<double> ContextDisambiguator::Score(
    const std::vector<ImagePair>& pairs) {
  num_requested_ += pairs.size();
  if (!bulk_done_ && options_.bulk_after_fraction > 0 &&
      options_.bulk_after_fraction < 1 &&
      num_requested_ >= static_cast<size_t>(options_.bulk_min_bridges)) {
    if (num_requested_ > options_.bulk_after_fraction * Bridges().size()) {
      MeasureAllBridges();
    }
  }
  std::vector<double> scores(pairs.size(), -1.0);
  std::vector<ImagePair> todo;
  std::vector<size_t> todo_index;
  for (size_t i = 0; i < pairs.size(); ++i) {
    const PairId id =
        ImagePairToPairId(pairs[i].image_id1, pairs[i].image_id2);
    auto it = std::lower_bound(
        bulk_scores_.begin(), bulk_scores_.end(), id,
        [](const std::pair<PairId, double>& a, PairId b) {
          return a.first < b;
        });
    if (it != bulk_scores_.end() && it->first == id) {
      scores[i] = it->second;
    } else {
      todo.push_back(pairs[i]);
      todo_index.push_back(i);
    }
  }
  if (!todo.empty()) {
    const std::vector<double> measured = MeasureLazily(todo);
    for (size_t k = 0; k < todo.size(); ++k) {
      scores[todo_index[k]] = measured[k];
    }
  }
  return scores;
}

std::vector<double> ContextDisambiguator::MeasureLazily(
    const std::vector<ImagePair>& pairs) {
  for (const ImagePair& p : pairs) Prepare(p);
  std::vector<double> scores(pairs.size());
  const size_t num_threads = std::max<size_t>(
      1, std::min<size_t>(options_.num_threads, pairs.size()));
  // Thread w measures pairs [w n / T, (w + 1) n / T).
  RunOnThreads(num_threads, [&](size_t w, const Database& database,
                                CoverageGrid::Scratch* scratch) {
    for (size_t i = w * pairs.size() / num_threads;
         i < (w + 1) * pairs.size() / num_threads; ++i) {
      scores[i] = Measure(database, pairs[i], scratch).score;
    }
  });
  return scores;
}

}  // namespace hisfm
