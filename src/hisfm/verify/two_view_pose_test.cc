#include "hisfm/verify/two_view_pose.h"
#include "hisfm/verify/triangulation.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>

namespace hisfm {
namespace {

Eigen::Matrix3d Skew(const Eigen::Vector3d& t) {
  Eigen::Matrix3d s;
  s << 0, -t.z(), t.y(), t.z(), 0, -t.x(), -t.y(), t.x(), 0;
  return s;
}

double AngleDeg(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  return a.angularDistance(b) * 180.0 / M_PI;
}

struct Scene {
  Rigid3d cam2_from_cam1;
  std::vector<Eigen::Vector3d> points;
  std::vector<Eigen::Vector2d> x1, x2;
};

Scene RandomScene(uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  Scene s;
  const Eigen::Vector3d axis = Eigen::Vector3d(u(rng), u(rng), u(rng)).normalized();
  s.cam2_from_cam1 = Rigid3d(
      Eigen::Quaterniond(Eigen::AngleAxisd(0.4 * u(rng), axis)),
      Eigen::Vector3d(u(rng), 0.3 * u(rng), 0.2 * u(rng)).normalized());
  while (s.points.size() < 100) {
    const Eigen::Vector3d X(2 * u(rng), 2 * u(rng), 6 + 2 * u(rng));
    const Eigen::Vector3d Y = s.cam2_from_cam1 * X;
    if (Y.z() <= 0.5) continue;
    s.points.push_back(X);
    s.x1.push_back(X.hnormalized());
    s.x2.push_back(Y.hnormalized());
  }
  return s;
}

TEST(TwoViewPose, TriangulatesExactCorrespondences) {
  const Scene s = RandomScene(3);
  for (size_t k = 0; k < s.points.size(); ++k) {
    const Eigen::Vector3d X = TriangulatePoint(s.cam2_from_cam1, s.x1[k], s.x2[k]);
    EXPECT_LT((X - s.points[k]).norm(), 1e-6);
  }
  const double angle = TriangulationAngle(
      Eigen::Vector3d::Zero(), Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0.5, 0, 0.5));
  EXPECT_NEAR(angle, M_PI / 2, 1e-12);
}

TEST(TwoViewPose, RecoversThePoseFromEveryScaleAndSignOfE) {
  for (uint32_t seed = 1; seed <= 20; ++seed) {
    const Scene s = RandomScene(seed);
    const Eigen::Matrix3d E = Skew(s.cam2_from_cam1.translation) *
                              s.cam2_from_cam1.rotation.toRotationMatrix();
    for (double scale : {1.0, -3.5}) {
      Rigid3d pose;
      const int n = PoseFromEssential(scale * E, s.x1, s.x2, &pose);
      EXPECT_EQ(n, static_cast<int>(s.points.size()));
      EXPECT_LT(AngleDeg(pose.rotation, s.cam2_from_cam1.rotation), 1e-6);
      EXPECT_LT((pose.translation - s.cam2_from_cam1.translation).norm(), 1e-6);
    }
  }
}

TEST(TwoViewPose, DegenerateInputGivesNoPose) {
  Rigid3d pose;
  const Scene s = RandomScene(5);
  EXPECT_EQ(PoseFromEssential(Eigen::Matrix3d::Zero(), s.x1, s.x2, &pose), 0);
  EXPECT_EQ(PoseFromEssential(Eigen::Matrix3d::Identity(), {}, {}, &pose), 0);
}

TEST(TwoViewPose, EssentialOfGeometryUsesEOrConvertsF) {
  const Scene s = RandomScene(11);
  const Eigen::Matrix3d E = Skew(s.cam2_from_cam1.translation) *
                            s.cam2_from_cam1.rotation.toRotationMatrix();
  Eigen::Matrix3d K1, K2;
  K1 << 700, 0, 320, 0, 700, 240, 0, 0, 1;
  K2 << 650, 0, 300, 0, 650, 250, 0, 0, 1;
  const Eigen::Matrix3d F = K2.inverse().transpose() * E * K1.inverse();

  TwoViewGeometry calibrated;
  calibrated.config = static_cast<int>(TwoViewConfig::kCalibrated);
  calibrated.E = 2.0 * E;
  calibrated.F = F;
  EXPECT_TRUE(EssentialOfGeometry(calibrated, K1, K2).isApprox(2.0 * E));

  TwoViewGeometry uncalibrated;
  uncalibrated.config = static_cast<int>(TwoViewConfig::kUncalibrated);
  uncalibrated.F = F;
  uncalibrated.E = Eigen::Matrix3d::Identity();
  EXPECT_TRUE(EssentialOfGeometry(uncalibrated, K1, K2).isApprox(E));

  TwoViewGeometry empty;
  EXPECT_TRUE(EssentialOfGeometry(empty, K1, K2).isZero());
}

}  // namespace
}  // namespace hisfm
