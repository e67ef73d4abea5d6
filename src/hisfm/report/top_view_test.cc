#include "hisfm/report/top_view.h"

#include <gtest/gtest.h>

#include <cmath>

#include "hisfm/report/report_test_util.h"

namespace hisfm {
namespace {

Rigid3d Tilt() {
  return Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(
                     0.7, Eigen::Vector3d(1, 2, 0.5).normalized())),
                 Eigen::Vector3d(3, -1, 2));
}

TEST(TopViewFrame, RingIsSeenFromAboveAsACircle) {
  const Rigid3d world_from_local = Tilt();
  const Reconstruction model =
      testing_scene::RingModel(24, 50, 5.0, world_from_local);
  const TopViewFrame frame = ComputeTopViewFrame(model);
  const Eigen::Vector3d up = world_from_local.rotation * Eigen::Vector3d::UnitZ();
  EXPECT_NEAR(frame.axis_x.norm(), 1.0, 1e-9);
  EXPECT_NEAR(frame.axis_y.norm(), 1.0, 1e-9);
  EXPECT_NEAR(frame.axis_x.dot(frame.axis_y), 0.0, 1e-9);
  // Seen from above: the normal is the cameras' up direction.
  EXPECT_GT(frame.axis_x.cross(frame.axis_y).dot(up), 0.999);
  for (const auto& [id, image] : model.images) {
    EXPECT_NEAR(frame.Project(image.ProjectionCenter()).norm(), 5.0, 1e-6);
  }
  // Counter-clockwise around +z stays counter-clockwise in the drawing.
  const Eigen::Vector2d a = frame.Project(model.images.at(1).ProjectionCenter());
  const Eigen::Vector2d b = frame.Project(model.images.at(2).ProjectionCenter());
  EXPECT_GT(a.x() * b.y() - a.y() * b.x(), 0.0);
}

TEST(TopViewFrame, CollinearCamerasKeepTheLineAndLookDown) {
  // Cameras on a line along x, looking sideways (+y), z up.
  Reconstruction model;
  for (int i = 0; i < 6; ++i) {
    Image image;
    image.image_id = static_cast<ImageId>(i + 1);
    image.name = std::to_string(i);
    const Eigen::Vector3d c(i, 0, 0);
    image.cam_from_world = testing_scene::LookAt(
        c, c + Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitZ());
    model.images[image.image_id] = image;
  }
  const TopViewFrame frame = ComputeTopViewFrame(model);
  EXPECT_GT(std::abs(frame.axis_x.dot(Eigen::Vector3d::UnitX())), 0.999);
  EXPECT_GT(frame.axis_x.cross(frame.axis_y).dot(Eigen::Vector3d::UnitZ()),
            0.999);
}

// Photos along a shelf: the centres vary more in height than in depth, so
// the plane of their two main directions would be a front view.
TEST(TopViewFrame, PathWithHeightJitterIsSeenFromAbove) {
  Reconstruction model;
  for (int i = 0; i < 10; ++i) {
    Image image;
    image.image_id = static_cast<ImageId>(i + 1);
    image.name = std::to_string(i);
    const Eigen::Vector3d c(i, 0.01 * (i % 2), 0.3 * ((i * 7) % 3));
    image.cam_from_world = testing_scene::LookAt(
        c, c + Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitZ());
    model.images[image.image_id] = image;
  }
  const TopViewFrame frame = ComputeTopViewFrame(model);
  EXPECT_GT(frame.axis_x.cross(frame.axis_y).dot(Eigen::Vector3d::UnitZ()),
            0.999);
  EXPECT_GT(std::abs(frame.axis_x.dot(Eigen::Vector3d::UnitX())), 0.999);
  EXPECT_TRUE(frame.along_up);
}

// Cameras rolled at random do not agree on "up": the plane of the ring of
// centres is used.
TEST(TopViewFrame, RandomRollFallsBackToPrincipalPlane) {
  const Rigid3d world_from_local = Tilt();
  Reconstruction model = testing_scene::RingModel(20, 0, 5.0, world_from_local);
  int k = 0;
  for (auto& [id, image] : model.images) {
    const double roll = 2.39996 * k++;  // Golden angle: spread over 2 pi.
    image.cam_from_world.rotation =
        Eigen::Quaterniond(Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ())) *
        image.cam_from_world.rotation;
    image.cam_from_world.translation =
        -(image.cam_from_world.rotation *
          (world_from_local * Eigen::Vector3d(5 * std::cos(2 * M_PI * (id - 1) / 20),
                                              5 * std::sin(2 * M_PI * (id - 1) / 20),
                                              0)));
  }
  const TopViewFrame frame = ComputeTopViewFrame(model);
  const Eigen::Vector3d normal =
      world_from_local.rotation * Eigen::Vector3d::UnitZ();
  EXPECT_GT(std::abs(frame.axis_x.cross(frame.axis_y).dot(normal)), 0.999);
  EXPECT_FALSE(frame.along_up);
  for (const auto& [id, image] : model.images) {
    EXPECT_NEAR(frame.Project(image.ProjectionCenter()).norm(), 5.0, 1e-6);
  }
}

TEST(TopViewFrame, EmptyAndSingleCameraModels) {
  const TopViewFrame empty = ComputeTopViewFrame(Reconstruction());
  EXPECT_EQ(empty.Project(Eigen::Vector3d(1, 2, 3)), Eigen::Vector2d(1, 2));
  const Reconstruction one = testing_scene::RingModel(1, 0, 2.0);
  const TopViewFrame frame = ComputeTopViewFrame(one);
  EXPECT_NEAR(frame.axis_x.dot(frame.axis_y), 0.0, 1e-9);
  EXPECT_NEAR(frame.Project(one.images.at(1).ProjectionCenter()).norm(), 0.0,
              1e-9);
}

TEST(CommunityCircleLayout, SeparatesCommunities) {
  std::map<uint32_t, int> community_of;
  uint32_t id = 1;
  const std::vector<int> sizes = {7, 3, 1, 12, 5};
  for (size_t c = 0; c < sizes.size(); ++c) {
    for (int i = 0; i < sizes[c]; ++i) community_of[id++] = static_cast<int>(c);
  }
  const auto layout = CommunityCircleLayout(community_of);
  ASSERT_EQ(layout.size(), community_of.size());
  std::map<int, Eigen::Vector2d> centroid;
  std::map<int, int> count;
  for (const auto& [image, p] : layout) {
    EXPECT_LE(p.norm(), 1.0 + 1e-9);
    auto it = centroid.emplace(community_of[image], Eigen::Vector2d::Zero());
    it.first->second += p;
    ++count[community_of[image]];
  }
  for (auto& [c, p] : centroid) p /= count[c];
  // Every image is nearer to its own community's centroid than to others.
  for (const auto& [image, p] : layout) {
    const int own = community_of[image];
    for (const auto& [c, q] : centroid) {
      if (c == own) continue;
      EXPECT_LT((p - centroid[own]).norm(), (p - q).norm()) << image;
    }
  }
  // Distinct positions.
  for (const auto& [i, p] : layout) {
    for (const auto& [j, q] : layout) {
      if (i < j) {
        EXPECT_GT((p - q).norm(), 1e-3) << i << " " << j;
      }
    }
  }
}

TEST(AlignReferenceToModel, RecoversASimilarity) {
  const Reconstruction reference = testing_scene::RingModel(12, 0, 3.0);
  // The model: the reference moved by a similarity (scale 2).
  Sim3d truth;
  truth.scale = 2.0;
  truth.rotation = Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitZ());
  truth.translation = Eigen::Vector3d(1, 2, 3);
  Reconstruction model = reference;
  for (auto& [id, image] : model.images) {
    image.cam_from_world = truth.TransformPose(image.cam_from_world);
  }
  Sim3d estimate;
  size_t common = 0;
  ASSERT_TRUE(AlignReferenceToModel(model, reference, &estimate, &common));
  EXPECT_EQ(common, 12u);
  for (const auto& [id, image] : reference.images) {
    EXPECT_LT((estimate * image.ProjectionCenter() -
               model.images.at(id).ProjectionCenter())
                  .norm(),
              1e-6);
  }
  Reconstruction two = model;
  while (two.images.size() > 2) two.images.erase(two.images.begin());
  EXPECT_FALSE(AlignReferenceToModel(two, reference, &estimate, &common));
  EXPECT_EQ(common, 2u);
}

}  // namespace
}  // namespace hisfm
