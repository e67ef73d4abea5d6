#include "hisfm/verify/local_model.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <string>
#include <cmath>
#include <vector>

#include "hisfm/util/error.h"
#include "hisfm/verify/match_burstiness.h"
#include "hisfm/verify/street_test_scene.h"

namespace hisfm {
namespace {

// Pixel reprojection error of model point p in view v.
double PixelError(GeometryCache& cache, const LocalModel& model, int v,
                  size_t p) {
  const ImageGeometry& image = cache.Image(model.images[v]);
  const Eigen::Vector3d Y = model.cam_from_model[v] * model.points[p];
  if (!(Y.z() > 0)) return INFINITY;
  return (image.camera.NormalizedToPixel(Y.hnormalized()) -
          image.pixels[model.keypoints[v][p]])
      .norm();
}

// Share of a model's points whose keypoints all observe the same scene point.
double TrueTrackShare(const street_test::Scene& scene, const LocalModel& m) {
  size_t num_true = 0;
  for (size_t p = 0; p < m.points.size(); ++p) {
    const int point = scene.point_of_keypoint[m.images[0] - 1][m.keypoints[0][p]];
    bool ok = point >= 0;
    for (size_t v = 1; v < m.images.size() && ok; ++v) {
      if (m.keypoints[v][p] == LocalModel::kNoKeypoint) continue;
      ok = scene.point_of_keypoint[m.images[v] - 1][m.keypoints[v][p]] == point;
    }
    num_true += ok;
  }
  return m.points.empty() ? 0.0 : double(num_true) / m.points.size();
}

class LocalModelTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    street_ = new street_test::Opened(1, 16);
    cache_ = new GeometryCache(street_->db, street_->graph);
    cache_->SetKeypointDegrees(
        ComputeKeypointDegrees(street_->db, street_->graph));
  }
  static void TearDownTestSuite() {
    delete cache_;
    delete street_;
  }
  static street_test::Opened* street_;
  static GeometryCache* cache_;
};
street_test::Opened* LocalModelTest::street_ = nullptr;
GeometryCache* LocalModelTest::cache_ = nullptr;

// Checks what every model promises: the ego image first at the identity,
// unit baseline to images[1], every point observed by the ego image and
// reprojecting within max_reprojection_px where it is observed.
void ExpectWellFormed(GeometryCache& cache, const LocalModel& m,
                      const LocalModelOptions& options) {
  ASSERT_FALSE(m.empty());
  ASSERT_EQ(m.cam_from_model.size(), m.images.size());
  ASSERT_EQ(m.keypoints.size(), m.images.size());
  EXPECT_TRUE(m.cam_from_model[0].rotation.isApprox(
      Eigen::Quaterniond::Identity(), 1e-12));
  EXPECT_LT(m.cam_from_model[0].translation.norm(), 1e-12);
  EXPECT_NEAR(m.cam_from_model[1].Inverse().translation.norm(), 1.0, 1e-6);
  for (size_t v = 0; v < m.images.size(); ++v) {
    EXPECT_EQ(m.IndexOf(m.images[v]), static_cast<int>(v));
    ASSERT_EQ(m.keypoints[v].size(), m.points.size());
  }
  EXPECT_EQ(m.IndexOf(999), -1);
  for (size_t p = 0; p < m.points.size(); ++p) {
    ASSERT_NE(m.keypoints[0][p], LocalModel::kNoKeypoint);
    int num_views = 0;
    for (size_t v = 0; v < m.images.size(); ++v) {
      if (m.keypoints[v][p] == LocalModel::kNoKeypoint) continue;
      ++num_views;
      ASSERT_LT(m.keypoints[v][p], cache.Image(m.images[v]).pixels.size());
      EXPECT_LE(PixelError(cache, m, static_cast<int>(v), p),
                options.max_reprojection_px + 1e-6)
          << "point " << p << " view " << v;
    }
    EXPECT_GE(num_views, 2);
  }
  EXPECT_GE(m.num_checked, m.num_found);
  EXPECT_GE(m.num_found, 0);
  EXPECT_GE(m.Consistency(), 0.0);
  EXPECT_LE(m.Consistency(), 1.0);
  EXPECT_GT(m.num_cells, 0);
}

TEST_F(LocalModelTest, EgoModelsJoinTrueNeighboursWithTrueTracks) {
  const LocalModelOptions options;
  for (const ImageId ego : street_->graph.Images()) {
    SCOPED_TRACE("ego " + std::to_string(ego));
    const LocalModel m = BuildEgoModel(*cache_, street_->graph, ego,
                                       kInvalidImageId, options);
    ExpectWellFormed(*cache_, m, options);
    ASSERT_EQ(m.images.size(), 3u);
    EXPECT_EQ(m.images[0], ego);
    EXPECT_NE(m.images[1], m.images[2]);
    const std::vector<ImageId> candidates = StrongestNeighbours(
        street_->graph, ego, options.num_candidates);
    for (size_t v = 1; v < 3; ++v) {
      EXPECT_NE(std::find(candidates.begin(), candidates.end(), m.images[v]),
                candidates.end());
      // The street's repeated facades offer doppelganger neighbours; the
      // model covering the most of the image joins true ones.
      const ImageId other = m.images[v];
      EXPECT_EQ(street_->scene.shift.at(
                    ImagePair(std::min(ego, other), std::max(ego, other))),
                0);
    }
    EXPECT_GE(m.points.size(), 100u);
    EXPECT_GE(TrueTrackShare(street_->scene, m), 0.95);
  }
}

TEST_F(LocalModelTest, ExcludedImageIsNotInTheModel) {
  const LocalModelOptions options;
  const ImageId ego = 6;
  const LocalModel full =
      BuildEgoModel(*cache_, street_->graph, ego, kInvalidImageId, options);
  ASSERT_FALSE(full.empty());
  for (size_t v = 1; v < full.images.size(); ++v) {
    const LocalModel m =
        BuildEgoModel(*cache_, street_->graph, ego, full.images[v], options);
    ExpectWellFormed(*cache_, m, options);
    EXPECT_EQ(m.IndexOf(full.images[v]), -1);
    EXPECT_EQ(m.images[0], ego);
  }
  // An unknown exclusion changes nothing.
  const LocalModel same =
      BuildEgoModel(*cache_, street_->graph, ego, 999, options);
  EXPECT_EQ(same.images, full.images);
  EXPECT_EQ(same.points.size(), full.points.size());
}

TEST_F(LocalModelTest, TripletModelOfTrueNeighbours) {
  LocalModelOptions options;
  const ImageId ego = 8, a = 7, c = 9;
  ASSERT_FALSE(cache_->Pair(ego, a)->hypotheses.empty());
  ASSERT_FALSE(cache_->Pair(ego, c)->hypotheses.empty());
  const LocalModel m = BuildTripletModel(*cache_, ego, a, c, 0, 0, options);
  ExpectWellFormed(*cache_, m, options);
  EXPECT_EQ(m.images, (std::vector<ImageId>{ego, a, c}));
  EXPECT_GE(m.points.size(), 100u);
  EXPECT_GE(TrueTrackShare(street_->scene, m), 0.95);
  // Triplet points are seen in all three views.
  for (size_t p = 0; p < m.points.size(); ++p) {
    for (int v = 0; v < 3; ++v) {
      EXPECT_NE(m.keypoints[v][p], LocalModel::kNoKeypoint);
    }
  }
  // The pair's other hypothesis (reversed baseline) forms a worse model.
  if (cache_->Pair(ego, c)->hypotheses.size() > 1) {
    const LocalModel other =
        BuildTripletModel(*cache_, ego, a, c, 0, 1, options);
    EXPECT_LT(other.points.size(), m.points.size() / 2);
  }
  // A hypothesis that does not exist: no model.
  EXPECT_TRUE(BuildTripletModel(*cache_, ego, a, c, 0, 5, options).empty());
}

TEST_F(LocalModelTest, BundleAdjustmentRestoresPerturbedPoints) {
  LocalModelOptions options;
  options.bundle_adjust = false;
  const LocalModel m = BuildTripletModel(*cache_, 10, 9, 11, 0, 0, options);
  ASSERT_FALSE(m.empty());
  // Perturb points (about 1% of their depth) and the third camera.
  LocalModel perturbed = m;
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0, 0.01);
  for (Eigen::Vector3d& X : perturbed.points) {
    X += X.norm() * Eigen::Vector3d(n(rng), n(rng), n(rng));
  }
  perturbed.cam_from_model[2].translation += Eigen::Vector3d(0.02, -0.01, 0.0);
  auto mean_error = [&](const LocalModel& model) {
    double sum = 0;
    size_t count = 0;
    for (size_t p = 0; p < model.points.size(); ++p) {
      for (int v = 0; v < 3; ++v) {
        sum += std::min(100.0, PixelError(*cache_, model, v, p));
        ++count;
      }
    }
    return sum / count;
  };
  const double before = mean_error(perturbed);
  ASSERT_GT(before, 3 * options.max_reprojection_px);
  BundleAdjustModel(*cache_, options, &perturbed);
  ExpectWellFormed(*cache_, perturbed, options);
  EXPECT_LT(mean_error(perturbed), 1.0);
  // Most points survive.
  EXPECT_GT(perturbed.points.size(), m.points.size() * 8 / 10);
}

TEST_F(LocalModelTest, ConsistencyCountsNeedATriplet) {
  LocalModelOptions options;
  LocalModel m = BuildTripletModel(*cache_, 4, 3, 5, 0, 0, options);
  ASSERT_EQ(m.images.size(), 3u);
  CheckModelConsistency(*cache_, options, &m);
  EXPECT_GT(m.num_checked, 0);
  EXPECT_LE(m.num_found, m.num_checked);
  // Visibility limits that no point satisfies: nothing is checked.
  LocalModelOptions strict = options;
  strict.visibility.max_view_angle_deg = 1e-6;
  LocalModel s = m;
  CheckModelConsistency(*cache_, strict, &s);
  EXPECT_EQ(s.num_checked, 0);
  EXPECT_EQ(s.Consistency(), 1.0);
  // Not a triplet: zero counts.
  LocalModel pair = m;
  pair.images.pop_back();
  pair.cam_from_model.pop_back();
  pair.keypoints.pop_back();
  CheckModelConsistency(*cache_, options, &pair);
  EXPECT_EQ(pair.num_checked, 0);
  EXPECT_EQ(pair.num_found, 0);
}

TEST(LocalModel, ConsistencyAndIndexOf) {
  LocalModel m;
  EXPECT_TRUE(m.empty());
  EXPECT_EQ(m.Consistency(), 1.0);
  m.num_checked = 8;
  m.num_found = 2;
  EXPECT_DOUBLE_EQ(m.Consistency(), 0.25);
  m.images = {5, 3, 9};
  EXPECT_EQ(m.IndexOf(5), 0);
  EXPECT_EQ(m.IndexOf(9), 2);
  EXPECT_EQ(m.IndexOf(4), -1);
}

// Pair (1, 2) of two places: 1's neighbours 3 and 4, 2's neighbour 5, and 6
// seen about equally by both. 1 is glued to 5 by a doppelganger (5 is more
// than twice as strongly joined to 2), and 2 to 4 (4 is 1's).
TEST(SideNeighbours, LeaveOutTheOtherSideAndKeepSharedNeighbours) {
  const ViewGraph graph = ViewGraph::FromEdges(
      {1, 2, 3, 4, 5, 6},
      {{ImagePair(1, 2), 500}, {ImagePair(1, 3), 900}, {ImagePair(1, 4), 300},
       {ImagePair(1, 5), 400}, {ImagePair(1, 6), 350}, {ImagePair(2, 5), 1000},
       {ImagePair(2, 4), 100}, {ImagePair(2, 6), 400}, {ImagePair(3, 4), 50}});
  // 1: by weight 3, 2, 5, 6, 4; 2 is the pair's other image and 5 belongs
  // to 2 (400 < 0.5 * 1000); 6 is shared (350 >= 0.5 * 400).
  EXPECT_EQ(SideNeighbours(graph, 1, 2, 4, 0.5),
            (std::vector<ImageId>{3, 6, 4}));
  // 2: by weight 5, 1, 6, 4; 4 belongs to 1 (100 < 0.5 * 300).
  EXPECT_EQ(SideNeighbours(graph, 2, 1, 4, 0.5), (std::vector<ImageId>{5, 6}));
  // At most `count` neighbours, strongest first.
  EXPECT_EQ(SideNeighbours(graph, 1, 2, 2, 0.5), (std::vector<ImageId>{3, 6}));
  // Ratio 0 only leaves out the other image; ratio 1 splits every neighbour
  // seen by both by the stronger edge (6 goes to 2: 350 < 400).
  EXPECT_EQ(SideNeighbours(graph, 1, 2, 4, 0.0),
            (std::vector<ImageId>{3, 5, 6, 4}));
  EXPECT_EQ(SideNeighbours(graph, 1, 2, 4, 1.0), (std::vector<ImageId>{3, 4}));
  EXPECT_EQ(SideNeighbours(graph, 2, 1, 4, 1.0), (std::vector<ImageId>{5, 6}));
  // An unknown image has no side.
  EXPECT_TRUE(SideNeighbours(graph, 9, 1, 4, 0.5).empty());
}

TEST(PredictVisible, GeometryScaleAndViewingAngle) {
  ImageGeometry target;
  target.camera = CameraProjection(SimplePinholeCamera(1, 1000, 800, 500));
  const VisibilityOptions visibility;  // factor 2, 40 degrees
  const Rigid3d identity;
  Eigen::Vector2d pixel(-1, -1);
  // Straight ahead, observer beside the target camera.
  EXPECT_TRUE(PredictVisible(target, identity, Eigen::Vector3d(0, 0, 5),
                             Eigen::Vector3d(1, 0, 0), visibility, &pixel));
  EXPECT_NEAR(pixel.x(), 500, 1e-9);
  EXPECT_NEAR(pixel.y(), 400, 1e-9);
  // Pixel of an off-axis point.
  EXPECT_TRUE(PredictVisible(target, identity, Eigen::Vector3d(1, -0.5, 5),
                             Eigen::Vector3d(0.5, 0, 0), visibility, &pixel));
  EXPECT_NEAR(pixel.x(), 600, 1e-9);
  EXPECT_NEAR(pixel.y(), 350, 1e-9);
  // Behind the camera.
  EXPECT_FALSE(PredictVisible(target, identity, Eigen::Vector3d(0, 0, -5),
                              Eigen::Vector3d(0, 0, -10), visibility, &pixel));
  // Outside the image (x / z = 2 -> pixel 1500).
  EXPECT_FALSE(PredictVisible(target, identity, Eigen::Vector3d(10, 0, 5),
                              Eigen::Vector3d(10, 0, 0), visibility, &pixel));
  // Scale: the observer 1 unit from the point, the target 5 units.
  EXPECT_FALSE(PredictVisible(target, identity, Eigen::Vector3d(0, 0, 5),
                              Eigen::Vector3d(0, 0, 4), visibility, &pixel));
  // ... and the other way round.
  EXPECT_FALSE(PredictVisible(target, identity, Eigen::Vector3d(0, 0, 1),
                              Eigen::Vector3d(0, 0, -4), visibility, &pixel));
  // Within the factor: 5 against 3.
  EXPECT_TRUE(PredictVisible(target, identity, Eigen::Vector3d(0, 0, 5),
                             Eigen::Vector3d(0, 0, 2), visibility, &pixel));
  // Viewing angle: observer seeing the point from 60 degrees aside.
  const Eigen::Vector3d X(0, 0, 5);
  const Eigen::Vector3d side =
      X + 5 * Eigen::Vector3d(std::sin(M_PI / 3), 0, -std::cos(M_PI / 3));
  EXPECT_FALSE(PredictVisible(target, identity, X, side, visibility, &pixel));
  VisibilityOptions wide = visibility;
  wide.max_view_angle_deg = 70;
  EXPECT_TRUE(PredictVisible(target, identity, X, side, wide, &pixel));
  // The target's pose is applied: a camera moved 2 units along +x sees the
  // point 2 units to its left.
  const Rigid3d moved(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-2, 0, 0));
  EXPECT_TRUE(PredictVisible(target, moved, Eigen::Vector3d(0, 0, 5),
                             Eigen::Vector3d(0, 0, 0), visibility, &pixel));
  EXPECT_NEAR(pixel.x(), 500 - 500 * 2.0 / 5.0, 1e-9);
}

TEST(LocalModelOptions, CheckRejectsOutOfRangeValues) {
  EXPECT_NO_THROW(LocalModelOptions().Check());
  auto expect_throw = [](auto modify) {
    LocalModelOptions o;
    modify(o);
    EXPECT_THROW(o.Check(), Error);
  };
  expect_throw([](LocalModelOptions& o) { o.num_candidates = 1; });
  expect_throw([](LocalModelOptions& o) { o.max_reprojection_px = 0; });
  expect_throw([](LocalModelOptions& o) { o.min_points = 2; });
  expect_throw([](LocalModelOptions& o) { o.coverage_cell_px = 0; });
  expect_throw([](LocalModelOptions& o) { o.distinctive_degree_fraction = 0; });
  expect_throw([](LocalModelOptions& o) { o.min_triangulation_angle_deg = 90; });
  expect_throw([](LocalModelOptions& o) { o.visibility.max_scale_change = 0.5; });
  expect_throw([](LocalModelOptions& o) { o.visibility.max_view_angle_deg = 0; });
  expect_throw([](LocalModelOptions& o) { o.visibility.max_view_angle_deg = 181; });
}

}  // namespace
}  // namespace hisfm
