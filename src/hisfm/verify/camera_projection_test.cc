#include "hisfm/verify/camera_projection.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <random>

#include "hisfm/util/error.h"

namespace hisfm {
namespace {

TEST(CameraProjection, RoundTripsEverySupportedModel) {
  const std::vector<std::pair<int, std::vector<double>>> models = {
      {0, {800, 533.5, 400}},
      {1, {810, 790, 530, 402}},
      {2, {756, 533.5, 400, -0.05}},
      {3, {756, 533.5, 400, -0.05, 0.01}},
      {4, {760, 750, 533.5, 400, -0.04, 0.01, 0.001, -0.0005}},
  };
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-0.6, 0.6);
  for (const auto& [model_id, params] : models) {
    const CameraProjection cam(model_id, 1067, 800, params);
    for (int k = 0; k < 200; ++k) {
      const Eigen::Vector2d xy(u(rng), u(rng));
      const Eigen::Vector2d uv = cam.NormalizedToPixel(xy);
      const Eigen::Vector2d back = cam.PixelToNormalized(uv);
      EXPECT_LT((back - xy).norm(), 1e-9) << "model " << model_id;
    }
  }
}

TEST(CameraProjection, PinholeMatchesK) {
  const CameraProjection cam(1, 640, 480, {500, 510, 320, 240});
  const Eigen::Vector3d X(0.3, -0.2, 2.0);
  const Eigen::Vector3d h = cam.K() * X;
  EXPECT_LT((cam.NormalizedToPixel(X.hnormalized()) - h.hnormalized()).norm(),
            1e-12);
  EXPECT_DOUBLE_EQ(cam.MeanFocal(), 505);
  EXPECT_TRUE(cam.InImage(Eigen::Vector2d(10, 10), 5));
  EXPECT_FALSE(cam.InImage(Eigen::Vector2d(10, 10), 20));
  EXPECT_FALSE(cam.InImage(Eigen::Vector2d(641, 10)));
}

TEST(CameraProjection, RejectsUnsupportedModelsAndBadParameters) {
  EXPECT_THROW(CameraProjection(5, 100, 100, {1, 2, 3, 4, 5}), Error);
  EXPECT_THROW(CameraProjection(2, 100, 100, {1, 2, 3}), Error);
  EXPECT_THROW(CameraProjection(0, 100, 100, {-1, 2, 3}), Error);
  EXPECT_FALSE(CameraProjection::IsSupportedModel(9));
  EXPECT_TRUE(CameraProjection::IsSupportedModel(2));
}

}  // namespace
}  // namespace hisfm
