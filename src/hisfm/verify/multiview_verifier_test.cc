#include "hisfm/verify/multiview_verifier.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <memory>
#include <set>
#include <vector>

#include "hisfm/util/error.h"
#include "hisfm/verify/street_test_scene.h"

namespace hisfm {
namespace {

// The repeated test street (16 photos, seed 1; street_test_scene.h): pairs
// whose kept geometry has shift 0 are true, pairs with fewer than 20% true
// inliers are doppelgangers (the rest are mixed).
class MultiViewVerifierTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    street_ = new street_test::Opened(1, 16);
    verifier_ = new MultiViewVerifier(street_->db, street_->graph);
  }
  static void TearDownTestSuite() {
    delete verifier_;
    delete street_;
    verifier_ = nullptr;
    street_ = nullptr;
  }
  static bool IsTrue(const ImagePair& p) {
    return street_->scene.shift.at(p) == 0;
  }
  static bool IsDoppelganger(const ImagePair& p) {
    return street_->scene.true_fraction.at(p) < 0.2;
  }
  // Whether an inlier (oriented as stored) relates the same scene point.
  static bool IsTrueMatch(const ImagePair& p, const FeatureMatch& m) {
    const auto& k = street_->scene.point_of_keypoint;
    const int a = k[p.image_id1 - 1][m.idx1];
    return a >= 0 && a == k[p.image_id2 - 1][m.idx2];
  }

  // The street's first `n` pairs (all if fewer).
  static std::vector<ImagePair> FirstPairs(size_t n) {
    std::vector<ImagePair> pairs = street_->graph.Pairs();
    pairs.resize(std::min(pairs.size(), n));
    return pairs;
  }
  static MultiViewVerifierOptions Threads(int n) {
    MultiViewVerifierOptions options;
    options.num_threads = n;
    return options;
  }

  static street_test::Opened* street_;
  static MultiViewVerifier* verifier_;
};
street_test::Opened* MultiViewVerifierTest::street_ = nullptr;
MultiViewVerifier* MultiViewVerifierTest::verifier_ = nullptr;

TEST_F(MultiViewVerifierTest, TruePairsScoreAboveDoppelgangers) {
  std::vector<double> true_scores, doppelganger_scores;
  for (const ViewGraphEdge& e : street_->graph.Edges()) {
    const double s = verifier_->ScoreOf(e.pair);
    ASSERT_GE(s, 0.0);
    ASSERT_LE(s, 1.0);
    // The score is the calibrated score of the pair's features, which
    // carry its evidence.
    const PairFeatures f = verifier_->Features(e.pair);
    EXPECT_DOUBLE_EQ(s, CalibratedPairScore(f));
    const EdgeEvidence& ev = verifier_->Evaluate(e.pair);
    EXPECT_EQ(f.judged, ev.judged);
    EXPECT_EQ(f.num_unique, ev.num_unique);
    EXPECT_EQ(f.num_visible, ev.num_visible);
    EXPECT_EQ(f.num_found, ev.num_found);
    EXPECT_DOUBLE_EQ(f.agreement, std::min(ev.agreement_i, ev.agreement_j));
    EXPECT_GT(f.relative_burstiness, 0.0);
    EXPECT_LE(f.relative_burstiness, 1.0);
    if (IsTrue(e.pair)) {
      true_scores.push_back(s);
    } else if (IsDoppelganger(e.pair)) {
      doppelganger_scores.push_back(s);
    }
  }
  ASSERT_GE(true_scores.size(), 20u);
  ASSERT_GE(doppelganger_scores.size(), 40u);
  auto mean = [](const std::vector<double>& v) {
    double sum = 0;
    for (const double x : v) sum += x;
    return sum / v.size();
  };
  EXPECT_GT(mean(true_scores), mean(doppelganger_scores) + 0.1);
  // Area under the ROC curve: P(a true pair outscores a doppelganger).
  double auc = 0;
  for (const double t : true_scores) {
    for (const double d : doppelganger_scores) auc += t > d ? 1 : t == d ? 0.5 : 0;
  }
  auc /= true_scores.size() * doppelganger_scores.size();
  EXPECT_GT(auc, 0.65);
}

TEST_F(MultiViewVerifierTest, RelativeBurstinessIsOneOnlyForMutualStrongestPairs) {
  const ViewGraph& ranking = verifier_->RankingGraph();
  size_t num_mutual = 0;
  for (const ViewGraphEdge& e : ranking.Edges()) {
    const ImageId a = e.pair.image_id1, b = e.pair.image_id2;
    const std::vector<ImageId> best_a = StrongestNeighbours(ranking, a, 1);
    const std::vector<ImageId> best_b = StrongestNeighbours(ranking, b, 1);
    const bool mutual = ranking.Weight(a, best_a[0]) == e.weight &&
                        ranking.Weight(b, best_b[0]) == e.weight;
    if (!mutual) continue;
    ++num_mutual;
    EXPECT_DOUBLE_EQ(verifier_->Features(e.pair).relative_burstiness, 1.0);
  }
  EXPECT_GT(num_mutual, 0u);
  // A pair weaker than an image's strongest: the smaller ratio.
  const ViewGraphEdge& weakest = *std::min_element(
      ranking.Edges().begin(), ranking.Edges().end(),
      [](const ViewGraphEdge& x, const ViewGraphEdge& y) {
        return x.weight < y.weight;
      });
  double expected = 1;
  for (const ImageId id : {weakest.pair.image_id1, weakest.pair.image_id2}) {
    const ImageId best = StrongestNeighbours(ranking, id, 1)[0];
    expected = std::min(
        expected, double(weakest.weight) / ranking.Weight(id, best));
  }
  EXPECT_LT(expected, 1.0);
  EXPECT_DOUBLE_EQ(verifier_->Features(weakest.pair).relative_burstiness,
                   expected);
}

TEST_F(MultiViewVerifierTest, ScoreIsScoreOfInOrderAndComputedOnce) {
  std::vector<ImagePair> pairs = street_->graph.Pairs();
  pairs.resize(std::min<size_t>(pairs.size(), 12));
  std::reverse(pairs.begin(), pairs.end());
  const std::vector<double> scores = verifier_->Score(pairs);
  ASSERT_EQ(scores.size(), pairs.size());
  for (size_t k = 0; k < pairs.size(); ++k) {
    EXPECT_DOUBLE_EQ(scores[k], verifier_->ScoreOf(pairs[k]));
    EXPECT_DOUBLE_EQ(scores[k],
                     CalibratedPairScore(verifier_->Features(pairs[k])));
  }
  const size_t evaluated = verifier_->NumEvaluated();
  EXPECT_GE(evaluated, pairs.size());
  verifier_->Score(pairs);
  EXPECT_EQ(verifier_->NumEvaluated(), evaluated);
  // Evaluate returns the same evidence object each time.
  EXPECT_EQ(&verifier_->Evaluate(pairs[0]), &verifier_->Evaluate(pairs[0]));
  EXPECT_EQ(verifier_->Name(), "builtin");
}

// A pair's score and evidence do not depend on the number of threads, on
// batching or on the order pairs are met: one thread asked pair by pair
// agrees exactly with four threads scoring one reversed batch, and with
// four threads evaluating pair by pair (each pair's two models in
// parallel).
TEST_F(MultiViewVerifierTest, ScoresDoNotDependOnThreadsOrOrder) {
  const std::vector<ImagePair> pairs = FirstPairs(24);
  MultiViewVerifier serial(street_->db, street_->graph, Threads(1));
  MultiViewVerifier batched(street_->db, street_->graph, Threads(4));
  MultiViewVerifier paired(street_->db, street_->graph, Threads(4));
  std::vector<ImagePair> reversed(pairs.rbegin(), pairs.rend());
  const std::vector<double> batch = batched.Score(reversed);
  ASSERT_EQ(batch.size(), pairs.size());
  size_t judged = 0;
  for (size_t k = 0; k < pairs.size(); ++k) {
    const double expected = serial.Score({pairs[k]}).front();
    EXPECT_EQ(batch[pairs.size() - 1 - k], expected) << k;
    EXPECT_EQ(paired.ScoreOf(pairs[k]), expected) << k;
    const EdgeEvidence& a = serial.Evaluate(pairs[k]);
    const EdgeEvidence& b = batched.Evaluate(pairs[k]);
    EXPECT_EQ(a.judged, b.judged);
    EXPECT_EQ(a.hypothesis, b.hypothesis);
    EXPECT_EQ(a.num_visible, b.num_visible);
    EXPECT_EQ(a.num_found, b.num_found);
    EXPECT_EQ(a.consistent, b.consistent);
    judged += a.judged;
  }
  // The comparison covers pairs the edge test judged, not only silent ones.
  EXPECT_GT(judged, pairs.size() / 4);
  EXPECT_EQ(batched.NumEvaluated(), pairs.size());
}

TEST_F(MultiViewVerifierTest, RankingGraphHasTheSameImagesAndEdges) {
  const ViewGraph& ranking = verifier_->RankingGraph();
  EXPECT_EQ(ranking.Images(), street_->graph.Images());
  EXPECT_EQ(ranking.Pairs(), street_->graph.Pairs());
  // Burstiness weights differ from inlier counts.
  size_t num_different = 0;
  for (const ViewGraphEdge& e : street_->graph.Edges()) {
    num_different += ranking.Weight(e.pair.image_id1, e.pair.image_id2) !=
                     e.weight;
  }
  EXPECT_GT(num_different, 0u);
}

TEST_F(MultiViewVerifierTest, ConsistentSharesInABatchMatchOneByOne) {
  const std::vector<ImagePair> pairs = FirstPairs(16);
  MultiViewVerifier serial(street_->db, street_->graph, Threads(1));
  MultiViewVerifier batched(street_->db, street_->graph, Threads(4));
  const std::vector<ImagePair> reversed(pairs.rbegin(), pairs.rend());
  const std::vector<double> shares = batched.ConsistentShares(reversed);
  ASSERT_EQ(shares.size(), pairs.size());
  EXPECT_EQ(batched.NumEvaluated(), pairs.size());
  size_t partial = 0;
  for (size_t k = 0; k < pairs.size(); ++k) {
    const double expected = serial.ConsistentShare(pairs[k]);
    EXPECT_EQ(shares[pairs.size() - 1 - k], expected) << k;
    partial += expected < 1.0;
  }
  // Some pair loses inliers to the cleaning, so the shares say something.
  EXPECT_GT(partial, 0u);
  EXPECT_TRUE(batched.ConsistentShares({}).empty());
}

TEST_F(MultiViewVerifierTest, ConsistentInliersAreASubsetOfThePairsInliers) {
  size_t num_judged = 0, num_dropped = 0;
  size_t true_before = 0, all_before = 0, true_after = 0, all_after = 0;
  for (const ViewGraphEdge& e : street_->graph.Edges()) {
    if (e.pair.image_id2 > 9) continue;  // the first 9 images (fast)
    const std::vector<FeatureMatch> consistent =
        verifier_->ConsistentInliers(e.pair);
    const std::vector<FeatureMatch>& stored =
        verifier_->cache().Pair(e.pair.image_id1, e.pair.image_id2)->matches;
    ASSERT_EQ(stored.size(), e.weight);
    std::set<std::pair<Point2DIdx, Point2DIdx>> all;
    for (const FeatureMatch& m : stored) all.insert({m.idx1, m.idx2});
    std::set<std::pair<Point2DIdx, Point2DIdx>> seen;
    for (const FeatureMatch& m : consistent) {
      EXPECT_TRUE(all.count({m.idx1, m.idx2}))
          << e.pair.image_id1 << "-" << e.pair.image_id2;
      EXPECT_TRUE(seen.insert({m.idx1, m.idx2}).second) << "duplicate";
    }
    const EdgeEvidence& ev = verifier_->Evaluate(e.pair);
    EXPECT_DOUBLE_EQ(verifier_->ConsistentShare(e.pair),
                     stored.empty() ? 1.0
                                    : static_cast<double>(consistent.size()) /
                                          static_cast<double>(stored.size()));
    if (!ev.judged) {
      EXPECT_EQ(consistent.size(), stored.size());
      continue;
    }
    ++num_judged;
    ASSERT_EQ(ev.consistent.size(), stored.size());
    EXPECT_EQ(static_cast<int>(consistent.size()), ev.num_consistent);
    num_dropped += consistent.size() < stored.size();
    if (IsTrue(e.pair)) {
      for (const FeatureMatch& m : stored) {
        true_before += IsTrueMatch(e.pair, m);
        ++all_before;
      }
      for (const FeatureMatch& m : consistent) {
        true_after += IsTrueMatch(e.pair, m);
        ++all_after;
      }
    }
  }
  EXPECT_GT(num_judged, 10u);
  EXPECT_GT(num_dropped, 0u);
  // On true pairs the cleaning keeps most true matches and does not lower
  // their share.
  ASSERT_GT(all_after, 0u);
  EXPECT_GE(static_cast<double>(true_after) / all_after,
            static_cast<double>(true_before) / all_before - 1e-9);
  EXPECT_GT(true_after, true_before / 2);
}

TEST_F(MultiViewVerifierTest, EgoModelsAreCachedAndLieOnTheirSide) {
  const ImagePair pair = street_->graph.Pairs().front();
  const LocalModel& a = verifier_->EgoModel(pair.image_id1, pair.image_id2);
  const LocalModel& b = verifier_->EgoModel(pair.image_id1, pair.image_id2);
  EXPECT_EQ(&a, &b);
  if (!a.empty()) {
    EXPECT_EQ(a.images[0], pair.image_id1);
    EXPECT_EQ(a.IndexOf(pair.image_id2), -1);
  }
  // Every model of a tested pair lies on its own side: none of its images
  // is joined more than twice as strongly to the pair's other image.
  const ViewGraph& ranking = verifier_->RankingGraph();
  const double ratio = MultiViewVerifierOptions().other_side_ratio;
  const size_t count = MultiViewVerifierOptions().local_model.num_candidates;
  int num_models = 0;
  for (const ImagePair& p : street_->graph.Pairs()) {
    for (const auto& [ego, other] : {std::make_pair(p.image_id1, p.image_id2),
                                     std::make_pair(p.image_id2, p.image_id1)}) {
      const LocalModel& m = verifier_->EgoModel(ego, other);
      if (m.empty()) continue;
      ++num_models;
      // Its images are the ego image and neighbours of its side.
      const std::vector<ImageId> side =
          SideNeighbours(ranking, ego, other, count, ratio);
      for (size_t v = 1; v < m.images.size(); ++v) {
        EXPECT_NE(std::find(side.begin(), side.end(), m.images[v]), side.end());
      }
      for (size_t v = 1; v < m.images.size(); ++v) {
        EXPECT_GE(ranking.Weight(ego, m.images[v]),
                  ratio * ranking.Weight(other, m.images[v]))
            << ego << " " << other << " " << m.images[v];
      }
    }
  }
  EXPECT_GT(num_models, 10);
}

TEST_F(MultiViewVerifierTest, TrueTrianglesCloseInRotation) {
  // Every triangle of true pairs: the relative rotations compose to the
  // identity within the noise of the poses.
  const ViewGraph& g = street_->graph;
  size_t num_triangles = 0;
  for (const ViewGraphEdge& e : g.Edges()) {
    if (!IsTrue(e.pair)) continue;
    const ImageId a = e.pair.image_id1, b = e.pair.image_id2;
    for (const ImageId c : g.Images()) {
      if (c <= b || g.Weight(b, c) == 0 || g.Weight(a, c) == 0) continue;
      if (!IsTrue(ImagePair(b, c)) || !IsTrue(ImagePair(a, c))) continue;
      const double error = verifier_->CycleRotationErrorDeg({a, b, c});
      ASSERT_GE(error, 0.0);
      EXPECT_LT(error, 3.0) << a << " " << b << " " << c;
      // Walked the other way round: the same loop.
      EXPECT_NEAR(verifier_->CycleRotationErrorDeg({c, b, a}), error, 1e-6);
      ++num_triangles;
    }
  }
  EXPECT_GT(num_triangles, 10u);
  Eigen::Quaterniond ab, ba;
  const ImagePair p = g.Edges()[0].pair;
  ASSERT_TRUE(verifier_->RelativeRotation(p.image_id1, p.image_id2, &ab));
  ASSERT_TRUE(verifier_->RelativeRotation(p.image_id2, p.image_id1, &ba));
  EXPECT_LT((ab * ba).angularDistance(Eigen::Quaterniond::Identity()), 1e-9);
}

TEST_F(MultiViewVerifierTest, CycleThroughAMissingPairIsUnknown) {
  const ImageId a = street_->graph.Images()[0];
  const ImageId absent = street_->graph.Images().back() + 1;
  EXPECT_LT(verifier_->CycleRotationErrorDeg({a, absent}), 0.0);
  EXPECT_LT(verifier_->CycleRotationErrorDeg({a}), 0.0);
}

TEST(MultiViewVerifierOptions, CheckRejectsOutOfRangeValues) {
  EXPECT_NO_THROW(MultiViewVerifierOptions().Check());
  MultiViewVerifierOptions o;
  o.geometry.keypoint_radius_px = 0;
  EXPECT_THROW(o.Check(), Error);
  o = MultiViewVerifierOptions();
  o.local_model.num_candidates = 1;
  EXPECT_THROW(o.Check(), Error);
  o = MultiViewVerifierOptions();
  o.edge_test.depth_tolerance = 1.5;
  EXPECT_THROW(o.Check(), Error);
  o = MultiViewVerifierOptions();
  o.geometry.relative_pose.num_samples = 0;
  EXPECT_THROW(o.Check(), Error);
  o = MultiViewVerifierOptions();
  o.other_side_ratio = 1.5;
  EXPECT_THROW(o.Check(), Error);
  o.other_side_ratio = -0.1;
  EXPECT_THROW(o.Check(), Error);
  o = MultiViewVerifierOptions();
  o.num_threads = -1;
  EXPECT_THROW(o.Check(), Error);
}

}  // namespace
}  // namespace hisfm
