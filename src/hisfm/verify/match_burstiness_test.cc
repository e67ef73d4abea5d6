#include "hisfm/verify/match_burstiness.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <vector>

#include "hisfm/io/database_writer.h"
#include "hisfm/util/test_util.h"
#include "hisfm/verify/view_graph_reader.h"

namespace hisfm {
namespace {

// Writes `num_images` images of `num_keypoints` keypoints each and the given
// inlier matches per pair.
void WriteDatabase(const std::string& path, int num_images, int num_keypoints,
                   const std::map<ImagePair, std::vector<FeatureMatch>>& pairs) {
  DatabaseWriter writer(path);
  writer.WriteCamera(SimplePinholeCamera(1, 640, 480, 500));
  for (int i = 1; i <= num_images; ++i) {
    writer.WriteImage({static_cast<ImageId>(i), "img" + std::to_string(i), 1});
    Keypoints keypoints(num_keypoints, 2);
    for (int k = 0; k < num_keypoints; ++k) {
      keypoints(k, 0) = static_cast<float>(10 + 5 * k);
      keypoints(k, 1) = static_cast<float>(20 + i);
    }
    writer.WriteKeypoints(static_cast<ImageId>(i), keypoints);
  }
  for (const auto& [pair, matches] : pairs) {
    TwoViewGeometry g;
    g.pair = pair;
    g.config = static_cast<int>(TwoViewConfig::kCalibrated);
    g.inlier_matches = matches;
    writer.WriteTwoViewGeometry(g);
  }
  writer.Close();
}

std::vector<FeatureMatch> Same(std::initializer_list<Point2DIdx> keypoints) {
  std::vector<FeatureMatch> m;
  for (const Point2DIdx k : keypoints) m.push_back({k, k});
  return m;
}

// Keypoint 0 of every image is matched in every pair it appears in; the
// others in one pair each.
std::map<ImagePair, std::vector<FeatureMatch>> SmallPairs() {
  return {{ImagePair(1, 2), Same({0, 1, 2, 3})},
          {ImagePair(1, 3), Same({0, 4})},
          {ImagePair(1, 4), Same({0})},
          {ImagePair(2, 3), Same({0, 5})},
          {ImagePair(3, 4), Same({0})}};
}

TEST(MatchBurstiness, KeypointDegreesCountPairsOfTheGraph) {
  TempDir dir("hisfm-burstiness");
  WriteDatabase(dir / "db.db", 4, 10, SmallPairs());
  const Database db(dir / "db.db");
  const ViewGraph graph = ReadViewGraph(db, 1);
  ASSERT_EQ(graph.NumEdges(), 5u);
  const KeypointDegrees d = ComputeKeypointDegrees(db, graph);
  ASSERT_EQ(d.size(), 4u);
  for (const auto& [id, degrees] : d) EXPECT_EQ(degrees.size(), 10u);
  EXPECT_EQ(d.at(1), (std::vector<uint16_t>{3, 1, 1, 1, 1, 0, 0, 0, 0, 0}));
  EXPECT_EQ(d.at(2), (std::vector<uint16_t>{2, 1, 1, 1, 0, 1, 0, 0, 0, 0}));
  EXPECT_EQ(d.at(3), (std::vector<uint16_t>{3, 0, 0, 0, 1, 1, 0, 0, 0, 0}));
  EXPECT_EQ(d.at(4), (std::vector<uint16_t>{2, 0, 0, 0, 0, 0, 0, 0, 0, 0}));

  // Only the graph's pairs count: without (3, 4).
  std::vector<ViewGraphEdge> edges;
  for (const ViewGraphEdge& e : graph.Edges()) {
    if (e.pair != ImagePair(3, 4)) edges.push_back(e);
  }
  const ViewGraph smaller = ViewGraph::FromEdges(graph.Images(), edges);
  const KeypointDegrees d2 = ComputeKeypointDegrees(db, smaller);
  EXPECT_EQ(d2.at(3)[0], 2);
  EXPECT_EQ(d2.at(4)[0], 1);
  EXPECT_EQ(d2.at(1)[0], 3);
}

TEST(MatchBurstiness, WeightsSumInverseSquareRootsOfDegrees) {
  TempDir dir("hisfm-burstiness");
  WriteDatabase(dir / "db.db", 4, 10, SmallPairs());
  const Database db(dir / "db.db");
  const ViewGraph graph = ReadViewGraph(db, 1);
  const KeypointDegrees d = ComputeKeypointDegrees(db, graph);
  const auto w = BurstinessWeights(db, graph, d);
  ASSERT_EQ(w.size(), 5u);
  EXPECT_NEAR(w.at(ImagePair(1, 2)), 1 / std::sqrt(6.0) + 3, 1e-12);
  EXPECT_NEAR(w.at(ImagePair(1, 3)), 1 / 3.0 + 1, 1e-12);
  EXPECT_NEAR(w.at(ImagePair(1, 4)), 1 / std::sqrt(6.0), 1e-12);
  EXPECT_NEAR(w.at(ImagePair(2, 3)), 1 / std::sqrt(6.0) + 1, 1e-12);
  EXPECT_NEAR(w.at(ImagePair(3, 4)), 1 / std::sqrt(6.0), 1e-12);
  // Every inlier weighs at most 1: the weight never exceeds the count.
  for (const ViewGraphEdge& e : graph.Edges()) {
    EXPECT_LE(w.at(e.pair), e.weight + 1e-12);
    EXPECT_GT(w.at(e.pair), 0);
  }
}

TEST(MatchBurstiness, RepeatedContentRanksBelowUniqueContent) {
  // Six images in a row. Adjacent images share 8 unique features (degree
  // 1); images two or more apart share 20 features of a repeated pattern
  // (keypoints 0..19 of every image), a doppelganger with more inliers.
  const int n = 6;
  std::map<ImagePair, std::vector<FeatureMatch>> pairs;
  for (int i = 1; i <= n; ++i) {
    for (int j = i + 1; j <= n; ++j) {
      std::vector<FeatureMatch> m;
      if (j == i + 1) {
        // Keypoints 20..27 of i (towards i + 1), 30..37 of j (towards i).
        for (Point2DIdx k = 0; k < 8; ++k) m.push_back({20 + k, 30 + k});
      } else {
        for (Point2DIdx k = 0; k < 20; ++k) m.push_back({k, k});
      }
      pairs[ImagePair(i, j)] = m;
    }
  }
  TempDir dir("hisfm-burstiness");
  WriteDatabase(dir / "db.db", n, 40, pairs);
  const Database db(dir / "db.db");
  const ViewGraph graph = ReadViewGraph(db, 1);
  ASSERT_EQ(graph.NumEdges(), 15u);
  const KeypointDegrees d = ComputeKeypointDegrees(db, graph);
  // The pattern's keypoints are inliers of every non-adjacent pair.
  EXPECT_EQ(d.at(1)[0], 4);
  EXPECT_EQ(d.at(3)[5], 3);
  EXPECT_EQ(d.at(3)[20], 1);
  const auto w = BurstinessWeights(db, graph, d);
  for (int i = 1; i <= n; ++i) {
    // By inliers the strongest neighbour is a doppelganger; by burstiness
    // weight it is an adjacent image.
    const std::vector<ImageId> raw = StrongestNeighbours(graph, i, 1);
    ASSERT_EQ(raw.size(), 1u);
    EXPECT_GT(std::abs(int(raw[0]) - i), 1) << "image " << i;
    const ViewGraph reweighted = ReweightedGraph(graph, w);
    const std::vector<ImageId> best = StrongestNeighbours(reweighted, i, 1);
    ASSERT_EQ(best.size(), 1u);
    EXPECT_EQ(std::abs(int(best[0]) - i), 1) << "image " << i;
  }
  // A doppelganger's weight is its inlier count over the pattern's degrees.
  EXPECT_NEAR(w.at(ImagePair(1, 3)), 20 / std::sqrt(4.0 * 3.0), 1e-9);
  EXPECT_NEAR(w.at(ImagePair(1, 2)), 8.0, 1e-12);
}

TEST(MatchBurstiness, ReweightedGraphRoundsScalesAndKeepsEdges) {
  const ViewGraph graph = ViewGraph::FromEdges(
      {1, 2, 3, 4, 5},
      {{ImagePair(1, 2), 100}, {ImagePair(2, 3), 50}, {ImagePair(3, 4), 20}});
  std::unordered_map<ImagePair, double, ImagePairHash> w = {
      {ImagePair(1, 2), 3.456}, {ImagePair(2, 3), 0.001}};
  const ViewGraph r = ReweightedGraph(graph, w);
  EXPECT_EQ(r.Images(), graph.Images());
  ASSERT_EQ(r.NumEdges(), 3u);
  EXPECT_EQ(r.Weight(1, 2), 346u);  // round(100 * 3.456)
  EXPECT_EQ(r.Weight(2, 3), 1u);    // at least 1
  EXPECT_EQ(r.Weight(3, 4), 1u);    // no weight: 1
  const ViewGraph r10 = ReweightedGraph(graph, w, 10.0);
  EXPECT_EQ(r10.Weight(1, 2), 35u);
}

}  // namespace
}  // namespace hisfm
