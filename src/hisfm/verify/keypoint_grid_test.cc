#include "hisfm/verify/keypoint_grid.h"

#include <gtest/gtest.h>

#include <limits>
#include <random>
#include <vector>

namespace hisfm {
namespace {

bool BruteForceAnyWithin(const std::vector<Eigen::Vector2d>& points,
                         const Eigen::Vector2d& u, double radius) {
  for (const Eigen::Vector2d& p : points) {
    if ((p - u).squaredNorm() <= radius * radius) return true;
  }
  return false;
}

TEST(KeypointGrid, AgreesWithBruteForce) {
  std::mt19937 rng(4);
  for (const double radius : {3.0, 7.5, 40.0}) {
    const double width = 640, height = 480;
    std::uniform_real_distribution<double> ux(-20, width + 20);
    std::uniform_real_distribution<double> uy(-20, height + 20);
    // Some keypoints outside the image (clamped to the border cells).
    std::vector<Eigen::Vector2d> points;
    for (int k = 0; k < 400; ++k) points.emplace_back(ux(rng), uy(rng));
    const KeypointGrid grid(points, width, height, radius);
    EXPECT_EQ(grid.size(), points.size());
    int hits = 0, misses = 0;
    for (int q = 0; q < 5000; ++q) {
      // Queries near keypoints (within about 2 radii) and anywhere.
      Eigen::Vector2d u(ux(rng), uy(rng));
      if (q % 2 == 0) {
        std::uniform_real_distribution<double> d(-2 * radius, 2 * radius);
        u = points[q % points.size()] + Eigen::Vector2d(d(rng), d(rng));
      }
      const bool expected = BruteForceAnyWithin(points, u, radius);
      ASSERT_EQ(grid.AnyWithin(u), expected)
          << "radius " << radius << " query " << u.transpose();
      (expected ? hits : misses)++;
    }
    // Both outcomes were exercised.
    EXPECT_GT(hits, 100);
    EXPECT_GT(misses, 100);
  }
}

TEST(KeypointGrid, BoundaryOfTheRadiusIsInclusive) {
  const KeypointGrid grid({Eigen::Vector2d(100, 100)}, 200, 200, 5.0);
  EXPECT_TRUE(grid.AnyWithin(Eigen::Vector2d(105, 100)));
  EXPECT_TRUE(grid.AnyWithin(Eigen::Vector2d(103, 104)));  // distance 5
  EXPECT_FALSE(grid.AnyWithin(Eigen::Vector2d(105.01, 100)));
  EXPECT_FALSE(grid.AnyWithin(Eigen::Vector2d(104, 104)));  // distance 5.66
  // Across a cell border (cells of 5 px: 100 is the start of cell 20).
  EXPECT_TRUE(grid.AnyWithin(Eigen::Vector2d(96, 100)));
  EXPECT_TRUE(grid.AnyWithin(Eigen::Vector2d(100, 95.5)));
}

TEST(KeypointGrid, KeypointsAndQueriesOutsideTheImage) {
  const std::vector<Eigen::Vector2d> points = {
      {-2, -2}, {101, 50}, {50, 60.5}, {-100, 30}};
  const KeypointGrid grid(points, 100, 60, 4.0);
  EXPECT_TRUE(grid.AnyWithin(Eigen::Vector2d(0, 0)));
  EXPECT_TRUE(grid.AnyWithin(Eigen::Vector2d(-4, -3)));
  EXPECT_TRUE(grid.AnyWithin(Eigen::Vector2d(98, 50)));
  EXPECT_TRUE(grid.AnyWithin(Eigen::Vector2d(50, 58)));
  EXPECT_TRUE(grid.AnyWithin(Eigen::Vector2d(-101, 31)));
  // Clamped into the same border cell, but far away.
  EXPECT_FALSE(grid.AnyWithin(Eigen::Vector2d(1, 30)));
  EXPECT_FALSE(grid.AnyWithin(Eigen::Vector2d(-50, 30)));
}

TEST(KeypointGrid, EmptyGridAndNonFiniteQueries) {
  const KeypointGrid empty;
  EXPECT_EQ(empty.size(), 0u);
  EXPECT_FALSE(empty.AnyWithin(Eigen::Vector2d(0, 0)));
  const KeypointGrid none({}, 100, 100, 3);
  EXPECT_FALSE(none.AnyWithin(Eigen::Vector2d(50, 50)));
  const KeypointGrid grid({Eigen::Vector2d(10, 10)}, 100, 100, 3);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  EXPECT_FALSE(grid.AnyWithin(Eigen::Vector2d(nan, 10)));
  EXPECT_FALSE(grid.AnyWithin(Eigen::Vector2d(10, inf)));
  EXPECT_TRUE(grid.AnyWithin(Eigen::Vector2d(10, 10)));
}

TEST(KeypointGrid, RadiusLargerThanTheImage) {
  const KeypointGrid grid({Eigen::Vector2d(5, 5)}, 10, 10, 50);
  EXPECT_TRUE(grid.AnyWithin(Eigen::Vector2d(40, 30)));
  EXPECT_FALSE(grid.AnyWithin(Eigen::Vector2d(60, 5)));
}

}  // namespace
}  // namespace hisfm
