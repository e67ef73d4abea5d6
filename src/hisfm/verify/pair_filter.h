// A view-graph pre-filter that removes pairs explained by repeated structure.
//
// The HiSfM hierarchy trusts every image's strongest pairs: they form the
// top-1 communities and attach the leaves without verification (paper,
// Sec. III-A and III-C). In scenes whose repetition is seen several times in
// one photo (facades of identical houses, a 4-fold symmetric print), a
// doppelganger can be an image's strongest pair: two photos one house apart
// see the same-looking facade from the same place. Such pairs are removed
// before the hierarchy is built, by three cheap tests:
//  (A) distinctive support (track_consistency.h): the number of the pair's
//      inliers on consistent tracks, against the number expected from the
//      fraction its images show over all their pairs. A pair matching only
//      repeated structure holds almost none (Photo Tourism's inconsistent
//      tracks, Snavely et al. 2006; Wilson & Snavely, ICCV 2013). Removed:
//      less than min_distinctive_ratio of the expectation, with a Poisson
//      tail probability below distinctive_significance (so that pairs with
//      too few inliers to tell are kept).
//  (B) three-view consistency (three_view_consistency.h), on the pairs that
//      pass (A): for each image x of the pair and each of its
//      num_third_views most trustworthy other neighbours t (the pairs kept
//      by A holding the most distinctive inliers), the share of the pair's
//      inliers that agree, in three views, with the scale fixed by their
//      distinctive matches; a side scores its best third view and the pair
//      its worse judged side. A pair whose unique matches are true but whose
//      repeated matches are not (the right epipolar geometry with the wrong
//      baseline) fails here.
//  (C) coverage dominance, on the pairs that pass (A) and (B): among an
//      image's num_coverage_pairs strongest pairs, the one covering most of
//      the image (inlier cells on a grid, inlier_coverage.h) is its most
//      trustworthy; a pair that outranks it in inliers yet covers less than
//      min_relative_coverage of what it covers concentrates its matches on
//      part of the image, the signature of a doppelganger seen from a
//      near-identical virtual viewpoint (the two sides of a symmetric object
//      photographed from opposite directions). This is the coverage cue of
//      context_disambiguator.h with the image's best-covering strong pair as
//      the reference; it only touches pairs that would otherwise be among an
//      image's strongest, so weak pairs of partial overlap are never removed.
// All tests are self-calibrated (ratios against the images' own statistics
// or counts of geometrically consistent points) and silent when the
// evidence is too thin to judge: such pairs are kept.
//
// Measurements behind the defaults: docs/decisions.md (2026-11).
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <unordered_map>
#include <vector>

#include "hisfm/graph/view_graph.h"
#include "hisfm/io/database.h"
#include "hisfm/verify/three_view_consistency.h"
#include "hisfm/verify/track_consistency.h"

namespace hisfm {

struct PairFilterOptions {
  /// Test A: a pair is removed if its distinctive support ratio is below
  /// this (0 disables test A).
  double min_distinctive_ratio = 0.5;
  /// Test A removes a pair only if its shortfall of distinctive inliers is
  /// significant at this level (Poisson tail, DistinctiveSupport::p_value):
  /// pairs with too few inliers to tell are kept.
  double distinctive_significance = 0.01;
  /// Test B: a pair is removed if its three-view consistent fraction is
  /// below this (0 disables test B).
  double min_three_view_consistency = 0.5;
  /// Test B: strongest neighbours of each image tried as third views.
  int num_third_views = 3;
  ThreeViewOptions three_view;
  /// Test C: a pair outranking an image's best-covering strong pair is
  /// removed if it covers less than this fraction of what that pair covers
  /// (0 disables test C).
  double min_relative_coverage = 0.6;
  /// Test C: number of an image's strongest pairs searched for the
  /// best-covering one.
  int num_coverage_pairs = 3;
  /// Test C: cells along the longer image side of the coverage grid.
  int coverage_grid_cells = 10;
  /// Threads judging pairs in test B (0 = one per core). The result does
  /// not depend on it.
  int num_threads = 0;

  /// Throws hisfm::Error if an option is out of range.
  void Check() const;
};

/// Why a pair was removed.
struct RemovedPair {
  ImagePair pair;
  uint32_t num_inliers = 0;
  /// "distinctive" (test A), "three_view" (test B) or "coverage" (test C).
  std::string test;
  /// The failing ratio or fraction.
  double value = 0;
};

struct PairFilterResult {
  /// The input graph without the removed pairs (same images).
  ViewGraph graph;
  std::vector<RemovedPair> removed;
  size_t num_removed_distinctive = 0;
  size_t num_removed_three_view = 0;
  size_t num_removed_coverage = 0;
  /// Pairs test B judged.
  size_t num_three_view_judged = 0;
  /// Fraction of matched keypoints on inconsistent tracks.
  double inconsistent_track_fraction = 0;
  /// Images that had pairs before and have none after.
  size_t num_images_isolated = 0;
  double seconds = 0;
};

/// The outcome of one of the tests on a list of pairs.
struct PairTestResult {
  /// The pairs that pass, in input order.
  std::vector<ViewGraphEdge> kept;
  /// The pairs that fail, in input order.
  std::vector<RemovedPair> removed;
  /// Pairs the test could judge (test B; A and C judge every pair).
  size_t num_judged = 0;
};

/// Distinctive inliers of each pair (DistinctiveSupport::num_distinctive).
using DistinctiveCounts =
    std::unordered_map<ImagePair, uint32_t, ImagePairHash>;

/// Test A: removes the pairs whose distinctive support (`support[i]` for
/// `edges[i]`) is deficient (options.min_distinctive_ratio,
/// options.distinctive_significance); keeps every pair if
/// min_distinctive_ratio is 0.
PairTestResult TestDistinctiveSupport(
    const std::vector<ViewGraphEdge>& edges,
    const std::vector<DistinctiveSupport>& support,
    const PairFilterOptions& options);

/// Test B: removes the judged pairs whose three-view consistent fraction is
/// below options.min_three_view_consistency; each image's third views are
/// its neighbours among `edges` with the most distinctive inliers
/// (`num_distinctive`, 0 if absent), then the strongest. Keeps every pair
/// (none judged) if min_three_view_consistency is 0.
PairTestResult TestThreeViewConsistency(
    const Database& database, const TrackConsistency& tracks,
    const std::vector<ViewGraphEdge>& edges,
    const DistinctiveCounts& num_distinctive,
    const PairFilterOptions& options);

/// Test C: removes the pairs that outrank, among an image's
/// options.num_coverage_pairs strongest pairs of `edges`, its best-covering
/// pair while covering less than options.min_relative_coverage of what it
/// covers. `images` are the graph's images. Keeps every pair if
/// min_relative_coverage is 0.
PairTestResult TestCoverageDominance(const Database& database,
                                     const std::vector<ImageId>& images,
                                     const std::vector<ViewGraphEdge>& edges,
                                     const PairFilterOptions& options);

/// Runs tests A, B and C on every edge of `graph` (see the file comment).
PairFilterResult FilterAmbiguousPairs(const Database& database,
                                      const ViewGraph& graph,
                                      const PairFilterOptions& options);

/// Counts and timing of a filter run, for summaries:
/// {"pairs_before", "pairs_after", "removed_distinctive",
///  "removed_three_view", "removed_coverage", "three_view_judged",
///  "inconsistent_track_fraction", "images_isolated", "seconds"}.
/// `pairs_before` is the number of edges of the filtered input graph.
nlohmann::json PairFilterSummaryJson(const PairFilterResult& result,
                                     size_t pairs_before);

}  // namespace hisfm
