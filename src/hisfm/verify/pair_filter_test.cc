#include "hisfm/verify/pair_filter.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "hisfm/io/database_writer.h"
#include "hisfm/util/error.h"
#include "hisfm/util/test_util.h"
#include "hisfm/verify/street_test_scene.h"
#include "hisfm/verify/view_graph_reader.h"

namespace hisfm {
namespace {

TEST(PairFilterOptions, CheckRejectsBadValues) {
  PairFilterOptions o;
  EXPECT_NO_THROW(o.Check());
  o.min_distinctive_ratio = 1.5;
  EXPECT_THROW(o.Check(), Error);
  o = PairFilterOptions();
  o.min_three_view_consistency = -0.1;
  EXPECT_THROW(o.Check(), Error);
  o = PairFilterOptions();
  o.distinctive_significance = 0;
  EXPECT_THROW(o.Check(), Error);
  o = PairFilterOptions();
  o.num_third_views = 0;
  EXPECT_THROW(o.Check(), Error);
  o = PairFilterOptions();
  o.num_coverage_pairs = 1;
  EXPECT_THROW(o.Check(), Error);
  o = PairFilterOptions();
  o.num_threads = -1;
  EXPECT_THROW(o.Check(), Error);
  o = PairFilterOptions();
  o.three_view.max_error_px = 0;
  EXPECT_THROW(o.Check(), Error);
}

// Counts of a filtered street against its construction.
struct StreetOutcome {
  size_t true_pairs = 0;
  size_t true_kept = 0;
  size_t false_kept = 0;
};

StreetOutcome Count(const street_test::Scene& scene, const ViewGraph& kept) {
  StreetOutcome out;
  for (const auto& [pair, shift] : scene.shift) out.true_pairs += shift == 0;
  for (const ViewGraphEdge& e : kept.Edges()) {
    (scene.shift.at(e.pair) == 0 ? out.true_kept : out.false_kept)++;
  }
  return out;
}

TEST(FilterAmbiguousPairs, KeepsOnlyTruePairsOfARepeatedStreet) {
  for (uint32_t seed : {1u, 2u}) {
    TempDir dir("hisfm-pairfilter");
    const street_test::Scene scene =
        street_test::Write(dir / "database.db", {20, true, seed});
    Database db(dir / "database.db");
    const ViewGraph graph = ReadViewGraph(db, 15);
    const StreetOutcome before = Count(scene, graph);
    ASSERT_GT(before.false_kept, 2 * before.true_pairs);  // a hard scene

    const PairFilterResult result =
        FilterAmbiguousPairs(db, graph, PairFilterOptions());
    const StreetOutcome after = Count(scene, result.graph);
    EXPECT_EQ(after.false_kept, 0u) << "seed " << seed;
    EXPECT_EQ(after.true_kept, before.true_pairs) << "seed " << seed;
    EXPECT_EQ(result.num_images_isolated, 0u);
    EXPECT_EQ(result.graph.NumImages(), graph.NumImages());
    EXPECT_EQ(result.removed.size(),
              result.num_removed_distinctive + result.num_removed_three_view +
                  result.num_removed_coverage);
    EXPECT_GT(result.num_removed_distinctive, 0u);
    EXPECT_GT(result.num_removed_three_view, 0u);
    EXPECT_GT(result.inconsistent_track_fraction, 0.5);
    for (const RemovedPair& r : result.removed) {
      EXPECT_TRUE(r.test == "distinctive" || r.test == "three_view" ||
                  r.test == "coverage");
      EXPECT_LT(r.value, 0.6);
    }
    const nlohmann::json summary =
        PairFilterSummaryJson(result, graph.NumEdges());
    EXPECT_EQ(summary["pairs_before"], graph.NumEdges());
    EXPECT_EQ(summary["pairs_after"], result.graph.NumEdges());
    EXPECT_EQ(summary["removed_three_view"], result.num_removed_three_view);

    // Without the three-view test, mixed pairs (true ground, false facades)
    // survive: both tests are needed.
    PairFilterOptions no_three_view;
    no_three_view.min_three_view_consistency = 0;
    const PairFilterResult weaker =
        FilterAmbiguousPairs(db, graph, no_three_view);
    EXPECT_EQ(weaker.num_removed_three_view, 0u);
    EXPECT_GT(Count(scene, weaker.graph).false_kept, 0u);
  }
}

TEST(FilterAmbiguousPairs, KeepsEveryPairOfAUniqueStreet) {
  TempDir dir("hisfm-pairfilter");
  const street_test::Scene scene =
      street_test::Write(dir / "database.db", {20, false, 4});
  Database db(dir / "database.db");
  const ViewGraph graph = ReadViewGraph(db, 15);
  const PairFilterResult result =
      FilterAmbiguousPairs(db, graph, PairFilterOptions());
  EXPECT_TRUE(result.removed.empty());
  EXPECT_EQ(result.graph.NumEdges(), graph.NumEdges());
  EXPECT_LT(result.inconsistent_track_fraction, 0.02);
  EXPECT_GT(result.num_three_view_judged, graph.NumEdges() / 2);
}

// The three-view test judges pairs on several threads: the same pairs are
// removed, with the same values, on one, two or three.
TEST(FilterAmbiguousPairs, ThreadsDoNotChangeTheResult) {
  TempDir dir("hisfm-pairfilter");
  street_test::Write(dir / "database.db", {24, true, 5});
  Database db(dir / "database.db");
  const ViewGraph graph = ReadViewGraph(db, 15);
  PairFilterOptions options;
  options.num_threads = 1;
  const PairFilterResult serial = FilterAmbiguousPairs(db, graph, options);
  ASSERT_GT(serial.num_removed_three_view, 0u);
  for (const int threads : {2, 3}) {
    options.num_threads = threads;
    const PairFilterResult parallel = FilterAmbiguousPairs(db, graph, options);
    EXPECT_EQ(parallel.num_three_view_judged, serial.num_three_view_judged);
    ASSERT_EQ(parallel.removed.size(), serial.removed.size()) << threads;
    for (size_t k = 0; k < serial.removed.size(); ++k) {
      EXPECT_EQ(parallel.removed[k].pair, serial.removed[k].pair);
      EXPECT_EQ(parallel.removed[k].test, serial.removed[k].test);
      EXPECT_DOUBLE_EQ(parallel.removed[k].value, serial.removed[k].value);
    }
  }
}

// Image 1 (100 x 100 px, 10 x 10 cells) has a strong pair with image 2 whose
// inliers crowd into two cells, a weaker pair with image 3 spread over 40
// cells, and a weak pair with image 4 over 10 cells.
void WriteCoverageDatabase(const std::string& path) {
  DatabaseWriter writer(path);
  writer.WriteCamera(SimplePinholeCamera(1, 100, 100, 100));
  for (ImageId id = 1; id <= 4; ++id) {
    writer.WriteImage({id, "im" + std::to_string(id), 1});
    Keypoints k(200, 2);
    for (int r = 0; r < 200; ++r) {
      // Keypoints 0..99 in cells (0,0) and (1,0); 100..199 one per cell
      // of the whole grid (two rounds).
      if (r < 100) {
        k.row(r) << 2.0f + (r % 2) * 10.0f + 0.05f * r, 5.0f;
      } else {
        const int c = (r - 100) % 100;
        k.row(r) << 10.0f * (c % 10) + 5.0f, 10.0f * (c / 10) + 5.0f;
      }
    }
    writer.WriteKeypoints(id, k);
  }
  auto write = [&](ImageId b, int first, int count, int stride) {
    TwoViewGeometry g;
    g.pair = ImagePair(1, b);
    g.config = static_cast<int>(TwoViewConfig::kCalibrated);
    for (int k = 0; k < count; ++k) {
      const Point2DIdx idx = static_cast<Point2DIdx>(first + k * stride);
      g.inlier_matches.push_back({idx, idx});
    }
    writer.WriteTwoViewGeometry(g);
  };
  write(2, 0, 100, 1);   // 100 inliers, 2 cells
  write(3, 100, 80, 1);  // 80 inliers, 80 cells
  write(4, 100, 20, 2);  // 20 inliers, 20 cells
  writer.Close();
}

// The coverage database through the whole filter (tests A and B off).
TEST(FilterAmbiguousPairs, RemovesStrongPairsThatCoverLittle) {
  TempDir dir("hisfm-pairfilter");
  WriteCoverageDatabase(dir / "database.db");
  Database db(dir / "database.db");
  const ViewGraph graph = ReadViewGraph(db, 15);
  ASSERT_EQ(graph.NumEdges(), 3u);
  PairFilterOptions options;
  options.min_distinctive_ratio = 0;
  options.min_three_view_consistency = 0;
  const PairFilterResult result = FilterAmbiguousPairs(db, graph, options);
  ASSERT_EQ(result.removed.size(), 1u);
  EXPECT_EQ(result.removed[0].pair, ImagePair(1, 2));
  EXPECT_EQ(result.removed[0].test, "coverage");
  EXPECT_NEAR(result.removed[0].value, 2.0 / 80.0, 1e-12);
  EXPECT_EQ(result.num_removed_coverage, 1u);
  // The weak pair covers little too, but it does not outrank the
  // best-covering pair: it is kept.
  EXPECT_EQ(result.graph.NumEdges(), 2u);
  EXPECT_GT(result.graph.Weight(1, 4), 0u);

  options.min_relative_coverage = 0;
  EXPECT_TRUE(FilterAmbiguousPairs(db, graph, options).removed.empty());
}

// Test C alone: the strong pair crowding two cells is dominated by the
// best-covering pair (1, 3); the weak pair (1, 4) does not outrank it.
TEST(TestCoverageDominance, RemovesOnlyThePairsOutrankingTheBestCoverer) {
  TempDir dir("hisfm-pairfilter");
  WriteCoverageDatabase(dir / "database.db");
  Database db(dir / "database.db");
  const ViewGraph graph = ReadViewGraph(db, 15);
  const PairFilterOptions options;
  const PairTestResult c =
      TestCoverageDominance(db, graph.Images(), graph.Edges(), options);
  ASSERT_EQ(c.removed.size(), 1u);
  EXPECT_EQ(c.removed[0].pair, ImagePair(1, 2));
  EXPECT_EQ(c.removed[0].num_inliers, 100u);
  EXPECT_EQ(c.removed[0].test, "coverage");
  EXPECT_NEAR(c.removed[0].value, 2.0 / 80.0, 1e-12);
  ASSERT_EQ(c.kept.size(), 2u);
  EXPECT_EQ(c.kept[0].pair, ImagePair(1, 3));
  EXPECT_EQ(c.kept[1].pair, ImagePair(1, 4));

  // Only the two strongest pairs searched: (1, 3) is still the best coverer.
  PairFilterOptions two = options;
  two.num_coverage_pairs = 2;
  EXPECT_EQ(TestCoverageDominance(db, graph.Images(), graph.Edges(), two)
                .removed.size(),
            1u);
  // A lower bar than 2/80 keeps everything; so does 0 (test off).
  PairFilterOptions lenient = options;
  lenient.min_relative_coverage = 0.02;
  EXPECT_TRUE(TestCoverageDominance(db, graph.Images(), graph.Edges(), lenient)
                  .removed.empty());
  lenient.min_relative_coverage = 0;
  const PairTestResult off =
      TestCoverageDominance(db, graph.Images(), graph.Edges(), lenient);
  EXPECT_TRUE(off.removed.empty());
  EXPECT_EQ(off.kept.size(), 3u);
}

DistinctiveSupport MakeSupport(double ratio, double p_value) {
  DistinctiveSupport s;
  s.num_inliers = 100;
  s.num_distinctive = static_cast<uint32_t>(ratio * 50);
  s.image_fraction = 0.5;
  s.expected = 50;
  s.ratio = ratio;
  s.p_value = p_value;
  return s;
}

// Test A alone, on hand-made supports: a pair is removed only if both its
// ratio is low and the shortfall significant.
TEST(TestDistinctiveSupport, RemovesDeficientPairsOnly) {
  const std::vector<ViewGraphEdge> edges = {
      {ImagePair(1, 2), 100}, {ImagePair(1, 3), 90}, {ImagePair(2, 3), 80},
      {ImagePair(3, 4), 70}};
  const std::vector<DistinctiveSupport> support = {
      MakeSupport(0.1, 1e-6),   // deficient
      MakeSupport(0.1, 0.2),    // too few to tell: kept
      MakeSupport(0.9, 1e-6),   // enough distinctive inliers: kept
      MakeSupport(0.49, 0.009)  // just deficient
  };
  PairFilterOptions options;
  const PairTestResult a = TestDistinctiveSupport(edges, support, options);
  ASSERT_EQ(a.removed.size(), 2u);
  EXPECT_EQ(a.removed[0].pair, ImagePair(1, 2));
  EXPECT_EQ(a.removed[0].num_inliers, 100u);
  EXPECT_EQ(a.removed[0].test, "distinctive");
  EXPECT_DOUBLE_EQ(a.removed[0].value, 0.1);
  EXPECT_EQ(a.removed[1].pair, ImagePair(3, 4));
  EXPECT_DOUBLE_EQ(a.removed[1].value, 0.49);
  ASSERT_EQ(a.kept.size(), 2u);
  EXPECT_EQ(a.kept[0].pair, ImagePair(1, 3));
  EXPECT_EQ(a.kept[1].pair, ImagePair(2, 3));

  options.distinctive_significance = 0.005;  // (3, 4) no longer significant
  EXPECT_EQ(TestDistinctiveSupport(edges, support, options).removed.size(), 1u);
  options.min_distinctive_ratio = 0;  // test A off
  EXPECT_EQ(TestDistinctiveSupport(edges, support, options).kept.size(), 4u);
  EXPECT_THROW(TestDistinctiveSupport(edges, {support[0]}, options), Error);
}

// Test B alone on the pairs test A keeps of a repeated street: it removes
// mixed pairs (true ground, false facades), never a true pair, and the same
// pairs as in the whole filter.
TEST(TestThreeViewConsistency, RemovesFalsePairsTestAMisses) {
  TempDir dir("hisfm-pairfilter");
  const street_test::Scene scene =
      street_test::Write(dir / "database.db", {20, true, 1});
  Database db(dir / "database.db");
  const ViewGraph graph = ReadViewGraph(db, 15);
  const TrackConsistency tracks(db, graph);
  const PairFilterOptions options;
  std::vector<DistinctiveSupport> support;
  DistinctiveCounts num_distinctive;
  for (const ViewGraphEdge& e : graph.Edges()) {
    const std::vector<FeatureMatch> inliers =
        db.ReadInlierMatches(e.pair.image_id1, e.pair.image_id2);
    support.push_back(tracks.Support(e.pair, inliers));
  }
  const PairTestResult a =
      TestDistinctiveSupport(graph.Edges(), support, options);
  for (size_t i = 0; i < graph.NumEdges(); ++i) {
    num_distinctive[graph.Edges()[i].pair] = support[i].num_distinctive;
  }
  const PairTestResult b =
      TestThreeViewConsistency(db, tracks, a.kept, num_distinctive, options);
  ASSERT_GT(b.removed.size(), 0u);
  EXPECT_EQ(b.kept.size() + b.removed.size(), a.kept.size());
  EXPECT_GT(b.num_judged, b.removed.size());
  for (const RemovedPair& r : b.removed) {
    EXPECT_NE(scene.shift.at(r.pair), 0) << r.pair.image_id1 << "-"
                                         << r.pair.image_id2;
    EXPECT_EQ(r.test, "three_view");
    EXPECT_LT(r.value, options.min_three_view_consistency);
  }
  const PairFilterResult whole = FilterAmbiguousPairs(db, graph, options);
  EXPECT_EQ(whole.num_removed_distinctive, a.removed.size());
  EXPECT_EQ(whole.num_removed_three_view, b.removed.size());
  EXPECT_EQ(whole.num_three_view_judged, b.num_judged);

  PairFilterOptions off = options;
  off.min_three_view_consistency = 0;
  const PairTestResult none =
      TestThreeViewConsistency(db, tracks, a.kept, num_distinctive, off);
  EXPECT_TRUE(none.removed.empty());
  EXPECT_EQ(none.num_judged, 0u);
  EXPECT_EQ(none.kept.size(), a.kept.size());
}

}  // namespace
}  // namespace hisfm
