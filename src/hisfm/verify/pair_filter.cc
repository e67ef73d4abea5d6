#include "hisfm/verify/pair_filter.h"

#include <algorithm>
#include <unordered_map>

#include "hisfm/util/error.h"
#include "hisfm/util/logging.h"
#include "hisfm/util/parallel.h"
#include "hisfm/util/timer.h"
#include "hisfm/verify/inlier_coverage.h"

namespace hisfm {

void PairFilterOptions::Check() const {
  HISFM_CHECK_OPTION(min_distinctive_ratio,
                     min_distinctive_ratio >= 0 && min_distinctive_ratio <= 1,
                     "in [0, 1]");
  HISFM_CHECK_OPTION(distinctive_significance,
                     distinctive_significance > 0 &&
                     distinctive_significance <= 1,
                     "in (0, 1]");
  HISFM_CHECK_OPTION(min_three_view_consistency,
                     min_three_view_consistency >= 0 &&
                     min_three_view_consistency <= 1,
                     "in [0, 1]");
  HISFM_CHECK_OPTION(num_third_views, num_third_views >= 1, ">= 1");
  three_view.Check();
  HISFM_CHECK_OPTION(min_relative_coverage,
                     min_relative_coverage >= 0 && min_relative_coverage <= 1,
                     "in [0, 1]");
  HISFM_CHECK_OPTION(num_coverage_pairs, num_coverage_pairs >= 2, ">= 2");
  HISFM_CHECK_OPTION(coverage_grid_cells,
                     coverage_grid_cells >= 2 && coverage_grid_cells <= 100,
                     "in [2, 100]");
  HISFM_CHECK_OPTION(num_threads, num_threads >= 0, ">= 0");
}

PairTestResult TestDistinctiveSupport(
    const std::vector<ViewGraphEdge>& edges,
    const std::vector<DistinctiveSupport>& support,
    const PairFilterOptions& options) {
  ThrowUnless(support.size() == edges.size(),
              "TestDistinctiveSupport: one support per edge");
  PairTestResult result;
  result.num_judged = edges.size();
  for (size_t i = 0; i < edges.size(); ++i) {
    const ViewGraphEdge& e = edges[i];
    const DistinctiveSupport& s = support[i];
    if (options.min_distinctive_ratio > 0 &&
        s.Deficient(options.min_distinctive_ratio,
                    options.distinctive_significance)) {
      result.removed.push_back({e.pair, e.weight, "distinctive", s.ratio});
      continue;
    }
    result.kept.push_back(e);
  }
  return result;
}

namespace {

// Each image's neighbours among `edges` as (weight, neighbour), the most
// distinctive inliers first, then the strongest, then the smallest id: the
// third views of test B. The pairs whose unique content vouches best for
// their geometry come first (a mixed pair, with true unique and false
// repeated matches, makes a misleading third view, and it holds fewer
// distinctive inliers than a true pair of the same strength).
std::unordered_map<ImageId, std::vector<std::pair<uint32_t, ImageId>>>
RankThirdViews(const std::vector<ViewGraphEdge>& edges,
               const DistinctiveCounts& num_distinctive) {
  std::unordered_map<ImageId, std::vector<std::pair<uint32_t, ImageId>>>
      neighbours;
  for (const ViewGraphEdge& e : edges) {
    neighbours[e.pair.image_id1].push_back({e.weight, e.pair.image_id2});
    neighbours[e.pair.image_id2].push_back({e.weight, e.pair.image_id1});
  }
  for (auto& [id, list] : neighbours) {
    const ImageId x = id;
    auto distinctive = [&](ImageId t) {
      auto it = num_distinctive.find(ImagePair(x, t));
      return it == num_distinctive.end() ? 0u : it->second;
    };
    std::sort(list.begin(), list.end(), [&](const auto& a, const auto& b) {
      const uint32_t da = distinctive(a.second);
      const uint32_t db = distinctive(b.second);
      if (da != db) return da > db;
      return a.first > b.first || (a.first == b.first && a.second < b.second);
    });
  }
  return neighbours;
}

}  // namespace

PairTestResult TestThreeViewConsistency(
    const Database& database, const TrackConsistency& tracks,
    const std::vector<ViewGraphEdge>& edges,
    const DistinctiveCounts& num_distinctive,
    const PairFilterOptions& options) {
  PairTestResult result;
  if (options.min_three_view_consistency <= 0) {
    result.kept = edges;
    return result;
  }
  const auto neighbours = RankThirdViews(edges, num_distinctive);
  // Each pair is judged on its own (the shared cache is thread-safe), in
  // parallel; the verdicts are then collected in edge order.
  PairGeometryCache cache(database);
  struct Verdict {
    bool judged = false;
    double fraction = 1.0;
  };
  std::vector<Verdict> verdicts(edges.size());
  ParallelFor(edges.size(), options.num_threads, [&](size_t i) {
    const ViewGraphEdge& e = edges[i];
    const std::shared_ptr<const PairGeometryCache::PairGeometry> xy =
        cache.Pair(e.pair, /*keep=*/false);
    bool judged = false;
    double fraction = 1.0;
    for (const ImageId x : {e.pair.image_id1, e.pair.image_id2}) {
      const ImageId y = x == e.pair.image_id1 ? e.pair.image_id2
                                              : e.pair.image_id1;
      bool side_judged = false;
      double side = 0.0;
      int used = 0;
      for (const auto& [weight, t] : neighbours.at(x)) {
        if (t == y) continue;
        if (used++ >= options.num_third_views) break;
        const ThreeViewResult r = MeasureThreeViewConsistency(
            cache, tracks, *xy, x, t, options.three_view);
        if (!r.judged) continue;
        side_judged = true;
        side = std::max(side, r.fraction);
        // A side that passes cannot fail with more third views, and the
        // pair's value (its worse side) is recorded only when it fails.
        if (side >= options.min_three_view_consistency) break;
      }
      if (side_judged) {
        judged = true;
        fraction = std::min(fraction, side);
      }
    }
    verdicts[i] = {judged, fraction};
  }, /*grain=*/16);
  for (size_t i = 0; i < edges.size(); ++i) {
    const ViewGraphEdge& e = edges[i];
    const bool judged = verdicts[i].judged;
    const double fraction = verdicts[i].fraction;
    result.num_judged += judged;
    if (judged && fraction < options.min_three_view_consistency) {
      result.removed.push_back({e.pair, e.weight, "three_view", fraction});
      continue;
    }
    result.kept.push_back(e);
  }
  return result;
}

PairTestResult TestCoverageDominance(const Database& database,
                                     const std::vector<ImageId>& images,
                                     const std::vector<ViewGraphEdge>& edges,
                                     const PairFilterOptions& options) {
  PairTestResult result;
  result.num_judged = edges.size();
  if (options.min_relative_coverage <= 0) {
    result.kept = edges;
    return result;
  }
  const ViewGraph graph = ViewGraph::FromEdges(images, edges);
  CoverageGrid grid(database, options.coverage_grid_cells);
  std::unordered_map<ImagePair, double, ImagePairHash> dominated;
  for (ImageId x : graph.Images()) {
    std::vector<std::pair<uint32_t, ImageId>> strongest;
    for (size_t e : graph.IncidentEdges(graph.IndexOf(x))) {
      strongest.push_back({graph.Edges()[e].weight, graph.OtherEnd(e, x)});
    }
    std::sort(strongest.begin(), strongest.end(),
              [](const auto& a, const auto& b) {
                return a.first > b.first ||
                       (a.first == b.first && a.second < b.second);
              });
    if (strongest.size() > static_cast<size_t>(options.num_coverage_pairs)) {
      strongest.resize(options.num_coverage_pairs);
    }
    std::vector<int> cells;
    size_t best = 0;
    for (size_t k = 0; k < strongest.size(); ++k) {
      const std::vector<FeatureMatch> inliers =
          database.ReadInlierMatches(x, strongest[k].second);
      cells.push_back(grid.CoveredCells(x, inliers, x < strongest[k].second));
      if (cells[k] > cells[best]) best = k;
    }
    for (size_t k = 0; k < best; ++k) {
      const double relative =
          static_cast<double>(cells[k]) / std::max(1, cells[best]);
      if (relative < options.min_relative_coverage) {
        const ImagePair p(x, strongest[k].second);
        auto it = dominated.find(p);
        if (it == dominated.end() || it->second > relative) {
          dominated[p] = relative;
        }
      }
    }
  }
  for (const ViewGraphEdge& e : edges) {
    auto it = dominated.find(e.pair);
    if (it == dominated.end()) {
      result.kept.push_back(e);
      continue;
    }
    result.removed.push_back({e.pair, e.weight, "coverage", it->second});
  }
  return result;
}

PairFilterResult FilterAmbiguousPairs(const Database& database,
                                      const ViewGraph& graph,
                                      const PairFilterOptions& options) {
  options.Check();
  Timer timer;
  PairFilterResult result;
  const Database::ReadScope read_scope(database);
  // The tracks' read also keeps each pair's keypoints in its first image,
  // for test A without reading the inliers again (a bitmap or list of
  // indices a pair, keypoint_multisets.h: about 100 bytes a pair on the
  // 5,000-image dense street, whose filter judges 84k pairs). In edge order:
  // the reads come in pair-id order, and the tracks fail if a pair has no
  // two-view geometry.
  const std::unordered_map<ImageId, size_t> num_keypoints =
      database.ReadNumKeypoints();
  KeypointMultisets first_keypoints;
  std::vector<uint32_t> num_inliers;
  num_inliers.reserve(graph.NumEdges());
  const TrackConsistency tracks(
      database, graph, [&](const ImagePair& pair, FeatureMatchSpan inliers) {
        auto it = num_keypoints.find(pair.image_id1);
        first_keypoints.Add(it == num_keypoints.end() ? 0 : it->second,
                            inliers);
        num_inliers.push_back(static_cast<uint32_t>(inliers.size()));
      });
  result.inconsistent_track_fraction = tracks.InconsistentFraction();
  HISFM_LOG_DEBUG("pair filter: tracks of {} pairs ({:.2f} s)",
                  graph.NumEdges(), timer.ElapsedSeconds());

  std::vector<DistinctiveSupport> support;
  support.reserve(graph.NumEdges());
  for (size_t i = 0; i < graph.NumEdges(); ++i) {
    support.push_back(tracks.Support(graph.Edges()[i].pair, num_inliers[i],
                                     first_keypoints, i));
  }
  PairTestResult a = TestDistinctiveSupport(graph.Edges(), support, options);
  // Distinctive inliers of each pair kept by A: ranks third views for B.
  DistinctiveCounts num_distinctive;
  for (size_t i = 0; i < graph.NumEdges(); ++i) {
    num_distinctive[graph.Edges()[i].pair] = support[i].num_distinctive;
  }
  for (const RemovedPair& r : a.removed) num_distinctive.erase(r.pair);
  HISFM_LOG_DEBUG("pair filter: test A kept {} pairs ({:.2f} s)",
                  a.kept.size(), timer.ElapsedSeconds());

  PairTestResult b =
      TestThreeViewConsistency(database, tracks, a.kept, num_distinctive,
                               options);
  HISFM_LOG_DEBUG("pair filter: test B kept {} pairs ({:.2f} s)",
                  b.kept.size(), timer.ElapsedSeconds());

  PairTestResult c =
      TestCoverageDominance(database, graph.Images(), b.kept, options);

  result.num_removed_distinctive = a.removed.size();
  result.num_removed_three_view = b.removed.size();
  result.num_removed_coverage = c.removed.size();
  result.num_three_view_judged = b.num_judged;
  for (PairTestResult* t : {&a, &b, &c}) {
    result.removed.insert(result.removed.end(), t->removed.begin(),
                          t->removed.end());
  }
  result.graph = ViewGraph::FromEdges(graph.Images(), c.kept);
  for (ImageId id : graph.Images()) {
    if (!graph.IncidentEdges(graph.IndexOf(id)).empty() &&
        result.graph.IncidentEdges(result.graph.IndexOf(id)).empty()) {
      ++result.num_images_isolated;
    }
  }
  result.seconds = timer.ElapsedSeconds();
  return result;
}

nlohmann::json PairFilterSummaryJson(const PairFilterResult& result,
                                     size_t pairs_before) {
  return {{"pairs_before", pairs_before},
          {"pairs_after", result.graph.NumEdges()},
          {"removed_distinctive", result.num_removed_distinctive},
          {"removed_three_view", result.num_removed_three_view},
          {"removed_coverage", result.num_removed_coverage},
          {"three_view_judged", result.num_three_view_judged},
          {"inconsistent_track_fraction", result.inconsistent_track_fraction},
          {"images_isolated", result.num_images_isolated},
          {"seconds", result.seconds}};
}

}  // namespace hisfm
