#include "hisfm/recon/model_merge.h"

#include <gtest/gtest.h>

#include <random>

#include "hisfm/eval/similarity_alignment.h"
#include "hisfm/util/error.h"

namespace hisfm {
namespace {

// A scene of kNumPoints points seen by every camera of a row along x.
constexpr int kNumPoints = 60;

std::vector<Eigen::Vector3d> ScenePoints() {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> x(-2.0, 12.0), y(-2.0, 2.0),
      z(5.0, 10.0);
  std::vector<Eigen::Vector3d> points;
  for (int k = 0; k < kNumPoints; ++k) points.emplace_back(x(rng), y(rng), z(rng));
  return points;
}

// cam_from_world of camera `i` of the row (centre (i, 0, 0)).
Rigid3d CameraPose(int i) {
  const Eigen::Quaterniond q(
      Eigen::AngleAxisd(0.02 * i, Eigen::Vector3d::UnitY()));
  return Rigid3d(q, -(q * Eigen::Vector3d(i, 0, 0)));
}

// The model of images first..last (ids), in the frame `frame_from_world`:
// keypoint k of every image observes point k (point ids 1 + k).
Reconstruction RowModel(int first, int last, const Sim3d& frame_from_world) {
  const std::vector<Eigen::Vector3d> scene = ScenePoints();
  Reconstruction model;
  Camera camera;
  camera.camera_id = 1;
  camera.model_id = 0;
  camera.width = 640;
  camera.height = 480;
  camera.params = {500, 320, 240};
  model.cameras.emplace(1, camera);
  for (int k = 0; k < kNumPoints; ++k) {
    Point3D p;
    p.xyz = frame_from_world * scene[k];
    model.points3D.emplace(1 + k, p);
  }
  for (int i = first; i <= last; ++i) {
    Image image;
    image.image_id = i;
    image.camera_id = 1;
    image.name = std::to_string(i) + ".png";
    image.cam_from_world = frame_from_world.TransformPose(CameraPose(i));
    image.points2D.resize(kNumPoints);
    for (int k = 0; k < kNumPoints; ++k) {
      image.points2D[k].point3D_id = 1 + k;
      model.points3D.at(1 + k).track.push_back(
          {static_cast<ImageId>(i), static_cast<Point2DIdx>(k)});
    }
    model.images.emplace(i, image);
  }
  return model;
}

Sim3d SomeFrame() {
  Sim3d s;
  s.scale = 2.5;
  s.rotation = Eigen::Quaterniond(
      Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()));
  s.translation = Eigen::Vector3d(1, -2, 3);
  return s;
}

// Every image's centre and rotation agree with the row's (world frame).
void ExpectRowPoses(const Reconstruction& model) {
  for (const auto& [id, image] : model.images) {
    const Rigid3d truth = CameraPose(static_cast<int>(id));
    EXPECT_LT((image.ProjectionCenter() - truth.Inverse().translation).norm(),
              1e-6)
        << "image " << id;
    EXPECT_LT(image.cam_from_world.rotation.angularDistance(truth.rotation),
              1e-6)
        << "image " << id;
  }
}

// Every observation is listed once, on both sides.
void ExpectConsistentTracks(const Reconstruction& model) {
  size_t observed = 0;
  for (const auto& [id, image] : model.images) {
    for (const Point2D& p : image.points2D) {
      if (p.point3D_id != kInvalidPoint3DId) ++observed;
    }
  }
  EXPECT_EQ(observed, model.NumObservations());
  for (const auto& [pid, point] : model.points3D) {
    EXPECT_GE(point.track.size(), 2u);
    for (const TrackElement& el : point.track) {
      EXPECT_EQ(model.images.at(el.image_id).points2D[el.point2D_idx].point3D_id,
                pid);
    }
  }
}

TEST(ModelMerge, JoinsTwoModelsThroughOneSharedImage) {
  Reconstruction model = RowModel(1, 5, Sim3d());
  const Reconstruction other = RowModel(5, 9, SomeFrame());
  const ModelMergeStep step = MergeInto(other, {}, &model);
  EXPECT_TRUE(step.merged);
  EXPECT_EQ(step.num_common_images, 1u);
  EXPECT_EQ(step.num_correspondences, static_cast<size_t>(kNumPoints));
  EXPECT_EQ(step.num_inliers, static_cast<size_t>(kNumPoints));
  ASSERT_EQ(model.NumRegImages(), 9u);
  ExpectRowPoses(model);
  // The shared points are joined into one track over all nine images.
  EXPECT_EQ(model.NumPoints3D(), static_cast<size_t>(kNumPoints));
  for (const auto& [pid, point] : model.points3D) {
    EXPECT_EQ(point.track.size(), 9u);
  }
  ExpectConsistentTracks(model);
}

TEST(ModelMerge, RefusesModelsWhoseSharedPointsDisagree) {
  Reconstruction model = RowModel(1, 5, Sim3d());
  Reconstruction other = RowModel(5, 9, SomeFrame());
  // The shared image's keypoints observe other points in `other`: no
  // similarity maps one model onto the other.
  std::mt19937 rng(3);
  std::vector<Point3DId> ids;
  for (const Point2D& p : other.images.at(5).points2D) ids.push_back(p.point3D_id);
  std::shuffle(ids.begin(), ids.end(), rng);
  for (size_t k = 0; k < ids.size(); ++k) {
    other.images.at(5).points2D[k].point3D_id = ids[k];
  }
  const Reconstruction before = model;
  const ModelMergeStep step = MergeInto(other, {}, &model);
  EXPECT_FALSE(step.merged);
  EXPECT_EQ(step.num_correspondences, static_cast<size_t>(kNumPoints));
  EXPECT_LT(step.num_inliers, static_cast<size_t>(kNumPoints / 2));
  EXPECT_EQ(model.NumRegImages(), before.NumRegImages());
  EXPECT_EQ(model.NumPoints3D(), before.NumPoints3D());
}

TEST(ModelMerge, RefusesASharedImageWhosePosesDisagreeWithItsPoints) {
  Reconstruction model = RowModel(1, 5, Sim3d());
  Reconstruction other = RowModel(5, 9, SomeFrame());
  // `other` holds the shared image at a pose 20 degrees off its points (a
  // wrong registration): the similarity its poses give maps the points
  // elsewhere.
  Rigid3d& pose = other.images.at(5).cam_from_world;
  pose = Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(
                     0.35, Eigen::Vector3d::UnitX())),
                 Eigen::Vector3d::Zero()) *
         pose;
  const ModelMergeStep step = MergeInto(other, {}, &model);
  EXPECT_FALSE(step.merged);
  EXPECT_LT(step.num_inliers, static_cast<size_t>(kNumPoints / 2));
  EXPECT_EQ(model.NumRegImages(), 5u);
}

TEST(ModelMerge, RefusesModelsWithoutSharedImages) {
  Reconstruction model = RowModel(1, 4, Sim3d());
  const ModelMergeStep step = MergeInto(RowModel(5, 9, SomeFrame()), {}, &model);
  EXPECT_FALSE(step.merged);
  EXPECT_EQ(step.num_common_images, 0u);
  EXPECT_EQ(model.NumRegImages(), 4u);
}

TEST(ModelMerge, MergesAChainWhateverTheOrder) {
  // The largest model is the base; the second largest (12-20) shares only
  // with the smallest (8-12), which shares with the base (1-8): it can only
  // join on the second pass.
  Sim3d third = SomeFrame();
  third.scale = 0.3;
  const std::vector<Reconstruction> models = {
      RowModel(12, 20, third), RowModel(1, 10, Sim3d()),
      RowModel(8, 12, SomeFrame())};
  const ModelMergeResult result = MergeModels(models);
  EXPECT_EQ(result.base, 1u);
  EXPECT_EQ(result.NumMerged(), 2u);
  ASSERT_EQ(result.steps.size(), 2u);
  EXPECT_EQ(result.steps[0].model, 2u);
  EXPECT_EQ(result.steps[1].model, 0u);
  ASSERT_EQ(result.model.NumRegImages(), 20u);
  ExpectRowPoses(result.model);
  ExpectConsistentTracks(result.model);
}

TEST(ModelMerge, KeepsTheLargestWhenNothingJoins) {
  const std::vector<Reconstruction> models = {RowModel(1, 3, Sim3d()),
                                              RowModel(10, 15, SomeFrame())};
  const ModelMergeResult result = MergeModels(models);
  EXPECT_EQ(result.base, 1u);
  EXPECT_EQ(result.NumMerged(), 0u);
  ASSERT_EQ(result.steps.size(), 1u);
  EXPECT_FALSE(result.steps[0].merged);
  EXPECT_EQ(result.steps[0].num_images, 3u);
  EXPECT_EQ(result.model.NumRegImages(), 6u);
}

TEST(ModelMergeOptions, CheckRejectsOutOfRangeValues) {
  ModelMergeOptions options;
  EXPECT_NO_THROW(options.Check());
  options.min_inliers = 0;
  EXPECT_THROW(options.Check(), Error);
  options = {};
  options.max_relative_error = 0;
  EXPECT_THROW(options.Check(), Error);
  options = {};
  options.min_inlier_ratio = 1.5;
  EXPECT_THROW(options.Check(), Error);
}

}  // namespace
}  // namespace hisfm
