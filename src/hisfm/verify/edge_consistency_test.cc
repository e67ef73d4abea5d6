#include "hisfm/verify/edge_consistency.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <string>
#include <map>
#include <vector>

#include "hisfm/util/error.h"
#include "hisfm/verify/match_burstiness.h"
#include "hisfm/verify/street_test_scene.h"

namespace hisfm {
namespace {

// The repeated test street (16 photos, seed 1) with a geometry cache and
// ego models built as the verifier builds them (without the other image).
class EdgeConsistencyTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    street_ = new street_test::Opened(1, 16);
    cache_ = new GeometryCache(street_->db, street_->graph);
    cache_->SetKeypointDegrees(
        ComputeKeypointDegrees(street_->db, street_->graph));
    models_ = new std::map<std::pair<ImageId, ImageId>, LocalModel>();
  }
  static void TearDownTestSuite() {
    delete models_;
    delete cache_;
    delete street_;
  }
  static const LocalModel& Model(ImageId ego, ImageId exclude) {
    // The model depends on `exclude` only if it is a candidate.
    const std::vector<ImageId> candidates = StrongestNeighbours(
        street_->graph, ego, LocalModelOptions().num_candidates);
    if (std::find(candidates.begin(), candidates.end(), exclude) ==
        candidates.end()) {
      exclude = kInvalidImageId;
    }
    auto it = models_->find({ego, exclude});
    if (it != models_->end()) return it->second;
    return models_
        ->emplace(std::make_pair(ego, exclude),
                  BuildEgoModel(*cache_, street_->graph, ego, exclude,
                                LocalModelOptions()))
        .first->second;
  }
  static EdgeEvidence Test(const ImagePair& p,
                           const EdgeTestOptions& options = {}) {
    return TestEdge(*cache_, Model(p.image_id1, p.image_id2),
                    Model(p.image_id2, p.image_id1), p.image_id1, p.image_id2,
                    options);
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

  static street_test::Opened* street_;
  static GeometryCache* cache_;
  static std::map<std::pair<ImageId, ImageId>, LocalModel>* models_;
};
street_test::Opened* EdgeConsistencyTest::street_ = nullptr;
GeometryCache* EdgeConsistencyTest::cache_ = nullptr;
std::map<std::pair<ImageId, ImageId>, LocalModel>* EdgeConsistencyTest::models_ =
    nullptr;

void ExpectConsistentCounts(const EdgeEvidence& ev, size_t num_matches) {
  EXPECT_GE(ev.num_unique, ev.num_visible);
  EXPECT_GE(ev.num_visible, ev.num_found);
  EXPECT_GE(ev.num_found, 0);
  EXPECT_EQ(ev.num_missing(), ev.num_visible - ev.num_found);
  EXPECT_LE(ev.num_found_displaced, 4 * ev.num_visible);
  EXPECT_GE(ev.MissingFraction(), 0.0);
  EXPECT_LE(ev.MissingFraction(), 1.0);
  if (!ev.judged) {
    EXPECT_EQ(ev.hypothesis, -1);
    EXPECT_EQ(ev.num_unique, 0);
    EXPECT_TRUE(ev.consistent.empty());
    EXPECT_EQ(ev.num_consistent, 0);
    return;
  }
  EXPECT_GE(ev.hypothesis, 0);
  EXPECT_GE(ev.agreement_i, 0.0);
  EXPECT_LE(ev.agreement_i, 1.0);
  EXPECT_GE(ev.agreement_j, 0.0);
  EXPECT_LE(ev.agreement_j, 1.0);
  ASSERT_EQ(ev.consistent.size(), num_matches);
  EXPECT_EQ(ev.num_consistent,
            std::count(ev.consistent.begin(), ev.consistent.end(), 1));
}

TEST_F(EdgeConsistencyTest, TruePairsMissFewerPredictedPoints) {
  double true_missing = 0, doppelganger_missing = 0;
  int num_true = 0, num_doppelganger = 0;
  double true_consistent = 0;
  std::vector<double> true_fractions, doppelganger_fractions;
  for (const ViewGraphEdge& e : street_->graph.Edges()) {
    const bool is_true = IsTrue(e.pair);
    if (!is_true && !IsDoppelganger(e.pair)) continue;
    const EdgeEvidence ev = Test(e.pair);
    SCOPED_TRACE(std::to_string(e.pair.image_id1) + "-" +
                 std::to_string(e.pair.image_id2));
    ExpectConsistentCounts(ev, e.weight);
    if (!ev.judged || ev.num_unique < 5) continue;
    EXPECT_LT(ev.hypothesis,
              static_cast<int>(cache_->Pair(e.pair.image_id1, e.pair.image_id2)
                                   ->hypotheses.size()));
    (is_true ? true_fractions : doppelganger_fractions)
        .push_back(ev.MissingFraction());
    if (is_true) {
      true_missing += ev.MissingFraction();
      true_consistent += double(ev.num_consistent) / e.weight;
      ++num_true;
    } else {
      doppelganger_missing += ev.MissingFraction();
      ++num_doppelganger;
    }
  }
  ASSERT_GE(num_true, 10);
  ASSERT_GE(num_doppelganger, 10);
  // Seed 1: 0.13 against 0.71.
  EXPECT_LT(true_missing / num_true,
            doppelganger_missing / num_doppelganger - 0.25);
  // P(a doppelganger misses a larger share than a true pair): 0.998.
  double auc = 0;
  for (const double t : true_fractions) {
    for (const double d : doppelganger_fractions) {
      auc += d > t ? 1 : d == t ? 0.5 : 0;
    }
  }
  auc /= true_fractions.size() * doppelganger_fractions.size();
  EXPECT_GT(auc, 0.9);
  // True pairs keep most of their inliers as consistent.
  EXPECT_GT(true_consistent / num_true, 0.7);
}

TEST_F(EdgeConsistencyTest, RecordedMissingPointsMatchTheCount) {
  EdgeTestOptions options;
  options.record_missing = true;
  int num_with_missing = 0;
  // Pairs of image 1..6 only (fast), true and doppelganger.
  for (const ViewGraphEdge& e : street_->graph.Edges()) {
    if (e.pair.image_id2 > 6) continue;
    const ImagePair& p = e.pair;
    const EdgeEvidence ev = Test(p, options);
    ExpectConsistentCounts(ev, e.weight);
    ASSERT_EQ(static_cast<int>(ev.missing.size()), ev.num_missing());
    num_with_missing += !ev.missing.empty();
    const LocalModel& mi = Model(p.image_id1, p.image_id2);
    const LocalModel& mj = Model(p.image_id2, p.image_id1);
    for (const EdgeEvidence::MissingPoint& m : ev.missing) {
      ASSERT_TRUE(m.source == p.image_id1 || m.source == p.image_id2);
      const LocalModel& other = m.source == p.image_id1 ? mj : mi;
      EXPECT_NE(other.IndexOf(m.target), -1);
      const ImageGeometry& target = cache_->Image(m.target);
      EXPECT_TRUE(target.camera.InImage(m.pixel));
      // Missing: no keypoint of the target within the search radius.
      EXPECT_FALSE(target.grid.AnyWithin(m.pixel));
      EXPECT_LT(m.keypoint, cache_->Image(m.source).pixels.size());
    }
    // Recording changes no count.
    const EdgeEvidence plain = Test(p);
    EXPECT_EQ(plain.num_unique, ev.num_unique);
    EXPECT_EQ(plain.num_visible, ev.num_visible);
    EXPECT_EQ(plain.num_found, ev.num_found);
    EXPECT_TRUE(plain.missing.empty());
  }
  EXPECT_GT(num_with_missing, 0);
}

TEST_F(EdgeConsistencyTest, MissingOrMismatchedModelsAreNotJudged) {
  const ImagePair p(3, 4);
  const LocalModel& mi = Model(3, 4);
  const LocalModel& mj = Model(4, 3);
  ASSERT_FALSE(mi.empty());
  ASSERT_FALSE(mj.empty());
  EXPECT_FALSE(TestEdge(*cache_, LocalModel(), mj, 3, 4, {}).judged);
  EXPECT_FALSE(TestEdge(*cache_, mi, LocalModel(), 3, 4, {}).judged);
  // Models given in the wrong order (their ego images are not i and j).
  EXPECT_FALSE(TestEdge(*cache_, mj, mi, 3, 4, {}).judged);
  EXPECT_TRUE(TestEdge(*cache_, mi, mj, 3, 4, {}).judged);
  // More joining points than the pair has inliers: no hypothesis joins.
  EdgeTestOptions strict;
  strict.min_join_points = 100000;
  const EdgeEvidence ev = TestEdge(*cache_, mi, mj, 3, 4, strict);
  EXPECT_FALSE(ev.judged);
  EXPECT_TRUE(ev.consistent.empty());
}

// On the true pairs, the inliers kept as consistent at a tolerance of 1, 3
// and 6 times the support error: a wider tolerance keeps a superset, more of
// the true matches, and still drops the false ones (a false match on a
// repeated facade lies about a repetition off its model point).
TEST_F(EdgeConsistencyTest, WiderToleranceKeepsTrueMatchesOnly) {
  const std::vector<double> factors = {1, 3, 6};
  std::vector<size_t> true_kept(factors.size()), false_kept(factors.size());
  size_t num_true_matches = 0, num_false_matches = 0;
  for (const ViewGraphEdge& e : street_->graph.Edges()) {
    if (!IsTrue(e.pair) || e.pair.image_id2 > 10) continue;
    const std::vector<FeatureMatch>& matches =
        cache_->Pair(e.pair.image_id1, e.pair.image_id2)->matches;
    std::vector<EdgeEvidence> evidence;
    for (const double f : factors) {
      EdgeTestOptions options;
      options.inlier_error_factor = f;
      evidence.push_back(Test(e.pair, options));
    }
    if (!evidence[0].judged) continue;
    for (size_t k = 0; k < matches.size(); ++k) {
      const bool is_true = IsTrueMatch(e.pair, matches[k]);
      (is_true ? num_true_matches : num_false_matches) += 1;
      for (size_t f = 0; f < factors.size(); ++f) {
        ASSERT_TRUE(evidence[f].judged);
        if (f > 0 && evidence[f - 1].consistent[k]) {
          EXPECT_TRUE(evidence[f].consistent[k]) << "not a superset";
        }
        if (evidence[f].consistent[k]) {
          (is_true ? true_kept : false_kept)[f] += 1;
        }
      }
    }
  }
  ASSERT_GT(num_true_matches, 100u);
  ASSERT_GT(num_false_matches, 10u);
  for (size_t f = 0; f < factors.size(); ++f) {
    RecordProperty("true_kept_x" + std::to_string(int(factors[f])),
                   std::to_string(true_kept[f]));
    RecordProperty("false_kept_x" + std::to_string(int(factors[f])),
                   std::to_string(false_kept[f]));
  }
  EXPECT_GT(true_kept[2], true_kept[0]);
  // Seed 1: 4,911 / 5,706 / 5,894 of 6,016 true matches kept, 0 of 40
  // false ones at every factor.
  EXPECT_GT(true_kept[2], 0.9 * num_true_matches);
  EXPECT_LE(false_kept[2], 2u);
}

TEST(EdgeTestOptions, CheckRejectsOutOfRangeValues) {
  EXPECT_NO_THROW(EdgeTestOptions().Check());
  auto expect_throw = [](auto modify) {
    EdgeTestOptions o;
    modify(o);
    EXPECT_THROW(o.Check(), Error);
  };
  expect_throw([](EdgeTestOptions& o) { o.depth_tolerance = 0; });
  expect_throw([](EdgeTestOptions& o) { o.depth_tolerance = 1; });
  expect_throw([](EdgeTestOptions& o) { o.min_join_points = 0; });
  expect_throw([](EdgeTestOptions& o) { o.join_loss_px = 0; });
  expect_throw([](EdgeTestOptions& o) { o.occlusion_cell_px = 0; });
  expect_throw([](EdgeTestOptions& o) { o.occlusion_margin = -0.1; });
  expect_throw([](EdgeTestOptions& o) { o.inlier_error_factor = 0.5; });
  expect_throw([](EdgeTestOptions& o) { o.visibility.max_scale_change = 0.9; });
}

TEST(EdgeEvidence, MissingFraction) {
  EdgeEvidence ev;
  EXPECT_EQ(ev.MissingFraction(), 0.0);
  ev.num_unique = 20;
  ev.num_visible = 10;
  ev.num_found = 4;
  EXPECT_EQ(ev.num_missing(), 6);
  EXPECT_DOUBLE_EQ(ev.MissingFraction(), 0.3);
}

}  // namespace
}  // namespace hisfm
