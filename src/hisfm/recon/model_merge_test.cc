#include "hisfm/recon/model_merge.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <limits>
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
// keypoint k of every image observes point k (point ids 1 + k + id_offset).
Reconstruction RowModel(int first, int last, const Sim3d& frame_from_world,
                        Point3DId id_offset = 0) {
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
    model.points3D.emplace(1 + k + id_offset, p);
  }
  for (int i = first; i <= last; ++i) {
    Image image;
    image.image_id = i;
    image.camera_id = 1;
    image.name = std::to_string(i) + ".png";
    image.cam_from_world = frame_from_world.TransformPose(CameraPose(i));
    image.points2D.resize(kNumPoints);
    for (int k = 0; k < kNumPoints; ++k) {
      image.points2D[k].point3D_id = 1 + k + id_offset;
      model.points3D.at(1 + k + id_offset).track.push_back(
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

// The shared images' poses in `other` are off (each turned by 0.6 degrees
// about its centre, as a segment's end images are posed worst) while its
// points are right: the similarity of any one shared image turns the merged
// images with it; refitted to the points of all shared images it is exact.
TEST(ModelMerge, RefitsTheSimilarityToThePointsOfAllSharedImages) {
  const Reconstruction base = RowModel(1, 5, Sim3d());
  Reconstruction other = RowModel(3, 9, SomeFrame());
  const std::vector<Eigen::Vector3d> axes = {
      Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, 1, 1).normalized(),
      Eigen::Vector3d(1, -1, 0).normalized()};
  for (ImageId id = 3; id <= 5; ++id) {
    Rigid3d& pose = other.images.at(id).cam_from_world;
    const Eigen::Quaterniond turn(Eigen::AngleAxisd(0.01, axes[id - 3]));
    pose = Rigid3d(turn * pose.rotation, turn * pose.translation);
  }
  const auto worst_rotation_error = [](const Reconstruction& model) {
    double worst = 0;
    for (ImageId id = 6; id <= 9; ++id) {
      worst = std::max(
          worst, model.images.at(id).cam_from_world.rotation.angularDistance(
                     CameraPose(id).rotation));
    }
    return worst;
  };
  Reconstruction refined = base;
  const ModelMergeStep step = MergeInto(other, {}, &refined);
  ASSERT_TRUE(step.merged);
  EXPECT_EQ(step.num_inliers, 3u * kNumPoints);
  ASSERT_EQ(refined.NumRegImages(), 9u);
  EXPECT_LT(worst_rotation_error(refined), 1e-6);
  for (ImageId id = 6; id <= 9; ++id) {
    EXPECT_LT((refined.images.at(id).ProjectionCenter() -
               CameraPose(id).Inverse().translation)
                  .norm(),
              1e-6);
  }

  ModelMergeOptions one_image;
  one_image.refine_similarity = false;
  Reconstruction unrefined = base;
  ASSERT_TRUE(MergeInto(other, one_image, &unrefined).merged);
  EXPECT_GT(worst_rotation_error(unrefined), 0.005);

  one_image.num_refits = -1;
  EXPECT_THROW(one_image.Check(), Error);
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
  // `other`'s points sit at each other's places: no similarity maps them
  // onto the model's.
  std::vector<Eigen::Vector3d> xyz;
  for (const auto& [id, p] : other.points3D) xyz.push_back(p.xyz);
  std::mt19937 rng(3);
  std::shuffle(xyz.begin(), xyz.end(), rng);
  size_t k = 0;
  for (auto& [id, p] : other.points3D) p.xyz = xyz[k++];
  const Reconstruction before = model;
  const ModelMergeStep step = MergeInto(other, {}, &model);
  EXPECT_FALSE(step.merged);
  EXPECT_EQ(step.num_correspondences, static_cast<size_t>(kNumPoints));
  EXPECT_LT(step.num_inliers, static_cast<size_t>(kNumPoints / 2));
  EXPECT_EQ(model.NumRegImages(), before.NumRegImages());
  EXPECT_EQ(model.NumPoints3D(), before.NumPoints3D());
}

TEST(ModelMerge, KeepsTrackBookkeepingOfNewAndPartialPoints) {
  // Two more keypoints e1, e2 in the images of both models. `other` numbers
  // its points from 1001, uses a second camera for its new images, and has
  // two points the model lacks: `free_point` on e1 of the shared image 5
  // and of image 6 (added as a new point), and `lonely` on e2 of images 5
  // and 7, where the model's image 5 observes another point (`own`, at
  // another place): that keypoint stays with `own`, and `lonely`, left with
  // one observation, is dropped.
  const Point2DIdx e1 = kNumPoints, e2 = kNumPoints + 1;
  Reconstruction model = RowModel(1, 5, Sim3d());
  for (ImageId id = 1; id <= 5; ++id) model.images.at(id).points2D.resize(e2 + 1);
  Point3D own;
  own.xyz = Eigen::Vector3d(-1, 1, 6);
  own.track = {{4, e2}, {5, e2}};
  model.points3D.emplace(9000, own);
  model.images.at(4).points2D[e2].point3D_id = 9000;
  model.images.at(5).points2D[e2].point3D_id = 9000;
  Reconstruction other = RowModel(5, 9, SomeFrame(), 1000);
  for (ImageId id = 5; id <= 9; ++id) other.images.at(id).points2D.resize(e2 + 1);
  Camera second = other.cameras.at(1);
  second.camera_id = 2;
  second.params = {600, 320, 240};
  other.cameras.emplace(2, second);
  for (ImageId id = 6; id <= 9; ++id) other.images.at(id).camera_id = 2;
  Point3D free_point;
  free_point.xyz = SomeFrame() * Eigen::Vector3d(3, 1, 8);
  free_point.track = {{5, e1}, {6, e1}};
  other.points3D.emplace(5000, free_point);
  other.images.at(5).points2D[e1].point3D_id = 5000;
  other.images.at(6).points2D[e1].point3D_id = 5000;
  Point3D lonely;
  lonely.xyz = SomeFrame() * Eigen::Vector3d(4, 0, 9);
  lonely.track = {{5, e2}, {7, e2}};
  other.points3D.emplace(5001, lonely);
  other.images.at(5).points2D[e2].point3D_id = 5001;
  other.images.at(7).points2D[e2].point3D_id = 5001;

  const ModelMergeStep step = MergeInto(other, {}, &model);
  ASSERT_TRUE(step.merged);
  // 60 joined shared points and the disagreeing own/lonely one.
  EXPECT_EQ(step.num_correspondences, static_cast<size_t>(kNumPoints) + 1);
  EXPECT_EQ(step.num_inliers, static_cast<size_t>(kNumPoints));
  EXPECT_EQ(model.NumRegImages(), 9u);
  EXPECT_EQ(model.cameras.size(), 2u);
  EXPECT_EQ(model.cameras.at(2).params[0], 600);
  EXPECT_EQ(model.images.at(7).camera_id, 2u);
  ExpectRowPoses(model);
  // The 60 joined points, `own` and `free_point`.
  EXPECT_EQ(model.NumPoints3D(), static_cast<size_t>(kNumPoints) + 2);
  EXPECT_EQ(model.points3D.at(9000).track.size(), 2u);
  EXPECT_EQ(model.images.at(5).points2D[e2].point3D_id, 9000u);
  EXPECT_EQ(model.images.at(7).points2D[e2].point3D_id, kInvalidPoint3DId);
  const Point3DId free_id = model.images.at(5).points2D[e1].point3D_id;
  ASSERT_NE(free_id, kInvalidPoint3DId);
  EXPECT_EQ(model.images.at(6).points2D[e1].point3D_id, free_id);
  EXPECT_LT((model.points3D.at(free_id).xyz - Eigen::Vector3d(3, 1, 8)).norm(),
            1e-9);
  ExpectConsistentTracks(model);
}

TEST(ModelMerge, ImagesWithOtherKeypointsAreNotShared) {
  Reconstruction model = RowModel(1, 5, Sim3d());
  model.images.at(5).points2D.resize(kNumPoints - 1);
  for (auto& [id, point] : model.points3D) {
    point.track.erase(std::remove_if(point.track.begin(), point.track.end(),
                                     [](const TrackElement& el) {
                                       return el.image_id == 5 &&
                                              el.point2D_idx >= kNumPoints - 1;
                                     }),
                      point.track.end());
  }
  const ModelMergeStep step = MergeInto(RowModel(5, 9, SomeFrame()), {}, &model);
  EXPECT_FALSE(step.merged);
  EXPECT_EQ(step.num_common_images, 0u);
  EXPECT_EQ(step.num_correspondences, 0u);
}

// Gives the model COLMAP 3.12's rigs: one single-camera rig, one frame per
// image, the frame's pose the image's.
void AddSingleCameraRigs(Reconstruction* model) {
  Rig rig;
  rig.rig_id = 1;
  rig.ref_sensor = SensorId{SensorType::kCamera, 1};
  model->rigs = std::vector<Rig>{rig};
  model->frames = std::vector<Frame>();
  for (const auto& [id, image] : model->images) {
    Frame frame;
    frame.frame_id = id;
    frame.rig_id = 1;
    frame.rig_from_world = image.cam_from_world;
    frame.data.push_back({SensorId{SensorType::kCamera, 1}, id});
    model->frames->push_back(frame);
  }
}

TEST(ModelMerge, MergesSingleCameraRigsAndRefusesOthers) {
  Reconstruction model = RowModel(1, 5, Sim3d());
  Reconstruction other = RowModel(5, 9, SomeFrame());
  AddSingleCameraRigs(&model);
  AddSingleCameraRigs(&other);
  Reconstruction merged = model;
  ASSERT_TRUE(MergeInto(other, {}, &merged).merged);
  ASSERT_TRUE(merged.frames.has_value());
  ASSERT_EQ(merged.frames->size(), 9u);
  EXPECT_EQ(merged.rigs->size(), 1u);
  for (const Frame& frame : *merged.frames) {
    const Rigid3d truth = CameraPose(static_cast<int>(frame.frame_id));
    ASSERT_TRUE(frame.rig_from_world.has_value());
    EXPECT_LT((frame.rig_from_world->Inverse().translation -
               truth.Inverse().translation)
                  .norm(),
              1e-6)
        << "frame " << frame.frame_id;
  }
  // A rig with a second sensor is not merged, nor a model with rigs into
  // one without.
  Reconstruction rigged = other;
  (*rigged.rigs)[0].sensors.push_back({SensorId{SensorType::kCamera, 2}, {}});
  Reconstruction target = model;
  ModelMergeStep step = MergeInto(rigged, {}, &target);
  EXPECT_FALSE(step.merged);
  EXPECT_TRUE(step.rigs_refused);
  Reconstruction plain = RowModel(1, 5, Sim3d());
  step = MergeInto(other, {}, &plain);
  EXPECT_FALSE(step.merged);
  EXPECT_TRUE(step.rigs_refused);
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

TEST(ModelMerge, NeedsMostSharedPointsToAgree) {
  Reconstruction other = RowModel(5, 9, SomeFrame());
  // 24 of the 60 points of `other` sit three times as deep, seen from the
  // shared image, as they should: the similarity of the shared image's
  // poses and the median depth ratio maps only 36 (60%) onto the model's.
  // (crossing_streets_1000_s7, tuning: a sub-model merged through one image
  // with 12 of 23 shared points agreeing put 38 images at five times the
  // scale.)
  const Eigen::Vector3d center = other.images.at(5).ProjectionCenter();
  int k = 0;
  for (auto& [id, p] : other.points3D) {
    if (k++ % 5 < 2) p.xyz = center + 3.0 * (p.xyz - center);
  }
  ModelMergeOptions options;
  options.min_inlier_ratio = 0.5;
  Reconstruction model = RowModel(1, 5, Sim3d());
  ModelMergeStep step = MergeInto(other, options, &model);
  EXPECT_TRUE(step.merged);
  EXPECT_EQ(step.num_correspondences, static_cast<size_t>(kNumPoints));
  EXPECT_EQ(step.num_inliers, 36u);
  // The default needs 70%.
  model = RowModel(1, 5, Sim3d());
  step = MergeInto(other, ModelMergeOptions(), &model);
  EXPECT_FALSE(step.merged);
  EXPECT_EQ(step.num_inliers, 36u);
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

TEST(ModelMerge, AGivenBaseKeepsItsFrameAndCameras) {
  Reconstruction small = RowModel(1, 5, Sim3d());
  small.cameras.at(1).params[0] = 510;
  const std::vector<Reconstruction> models = {small,
                                              RowModel(5, 14, SomeFrame())};
  const ModelMergeResult result = MergeModels(models, {}, 0);
  EXPECT_EQ(result.base, 0u);
  EXPECT_EQ(result.NumMerged(), 1u);
  EXPECT_EQ(result.model.NumRegImages(), 14u);
  EXPECT_EQ(result.model.cameras.at(1).params[0], 510);
  ExpectRowPoses(result.model);
  EXPECT_THROW(MergeModels(models, {}, 2), Error);
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

std::vector<ImageId> ImageIds(const Reconstruction& model) {
  std::vector<ImageId> ids;
  for (const auto& [id, image] : model.images) ids.push_back(id);
  return ids;
}

// The pair (a, b) of two row images, keypoint k of `a` matched to keypoint
// (k + shift) % kNumPoints of `b`, stored as the database stores it.
PairMatches RowPair(ImageId a, ImageId b, int shift = 0, int count = kNumPoints) {
  PairMatches pm;
  pm.pair = ImagePair(a, b);
  for (int k = 0; k < count; ++k) {
    const Point2DIdx ka = static_cast<Point2DIdx>(k);
    const Point2DIdx kb = static_cast<Point2DIdx>((k + shift) % kNumPoints);
    pm.matches.push_back(a < b ? FeatureMatch{ka, kb} : FeatureMatch{kb, ka});
  }
  return pm;
}

TEST(MergeThroughMatches, JoinsModelsWithoutSharedImagesThroughAPair) {
  // The model holds the row's first or last images, `other` the rest in
  // another frame: the pair's lower id is in either of them.
  for (const bool model_first : {true, false}) {
    Reconstruction model =
        model_first ? RowModel(1, 4, Sim3d()) : RowModel(6, 9, Sim3d());
    const Reconstruction other = model_first
                                     ? RowModel(6, 9, SomeFrame(), 1000)
                                     : RowModel(1, 4, SomeFrame(), 1000);
    const ModelMergeStep step =
        MergeThroughMatches(other, {RowPair(4, 6)}, {}, &model);
    EXPECT_TRUE(step.merged);
    EXPECT_EQ(step.num_common_images, 0u);
    EXPECT_EQ(step.num_pairs, 1u);
    EXPECT_EQ(step.num_correspondences, static_cast<size_t>(kNumPoints));
    EXPECT_EQ(step.num_inliers, static_cast<size_t>(kNumPoints));
    ASSERT_EQ(model.NumRegImages(), 8u);
    ExpectRowPoses(model);
    // The matched points are joined into one track over all eight images.
    EXPECT_EQ(model.NumPoints3D(), static_cast<size_t>(kNumPoints));
    for (const auto& [pid, point] : model.points3D) {
      EXPECT_EQ(point.track.size(), 8u);
    }
    ExpectConsistentTracks(model);
  }
}

TEST(MergeThroughMatches, ReadsEachSideOfAMatchWithItsImage) {
  // `other`'s keypoint k observes point (k + 5) % kNumPoints: keypoint k of
  // image 4 and keypoint k - 5 of image 6 see one point. The pair is
  // stored with the lower id first whichever model holds it.
  const auto permuted = [](Reconstruction model) {
    for (auto& [id, image] : model.images) {
      std::vector<Point2D> moved(kNumPoints);
      for (int k = 0; k < kNumPoints; ++k) {
        moved[k] = image.points2D[(k + 5) % kNumPoints];
      }
      image.points2D = moved;
    }
    for (auto& [pid, point] : model.points3D) {
      for (TrackElement& el : point.track) {
        el.point2D_idx = static_cast<Point2DIdx>(
            (el.point2D_idx + kNumPoints - 5) % kNumPoints);
      }
    }
    return model;
  };
  for (const bool model_first : {true, false}) {
    Reconstruction model =
        model_first ? RowModel(1, 4, Sim3d()) : permuted(RowModel(6, 9, Sim3d()));
    const Reconstruction other = model_first
                                     ? permuted(RowModel(6, 9, SomeFrame(), 1000))
                                     : RowModel(1, 4, SomeFrame(), 1000);
    // Image 4's keypoint k matches image 6's keypoint k - 5.
    const ModelMergeStep step = MergeThroughMatches(
        other, {RowPair(4, 6, kNumPoints - 5)}, {}, &model);
    EXPECT_TRUE(step.merged) << "model_first " << model_first;
    EXPECT_EQ(step.num_inliers, static_cast<size_t>(kNumPoints));
    ExpectRowPoses(model);
    ExpectConsistentTracks(model);
  }
}

TEST(MergeThroughMatches, RefusesAPairMatchedOneRepeatOver) {
  // Every keypoint matched to another point's keypoint, as a doppelganger
  // pair matches one facade period over: no similarity maps the points.
  Reconstruction model = RowModel(1, 4, Sim3d());
  const Reconstruction other = RowModel(6, 9, SomeFrame(), 1000);
  const Reconstruction before = model;
  const ModelMergeStep step =
      MergeThroughMatches(other, {RowPair(4, 6, 7)}, {}, &model);
  EXPECT_FALSE(step.merged);
  EXPECT_EQ(step.num_correspondences, static_cast<size_t>(kNumPoints));
  EXPECT_LT(step.num_inliers, static_cast<size_t>(kNumPoints) / 2);
  EXPECT_EQ(model.NumRegImages(), before.NumRegImages());
  EXPECT_EQ(model.NumPoints3D(), before.NumPoints3D());
}

TEST(MergeThroughMatches, NeedsEnoughMatchedPointsAcrossTheModels) {
  Reconstruction model = RowModel(1, 4, Sim3d());
  const Reconstruction other = RowModel(6, 9, SomeFrame(), 1000);
  // A pair inside one model and a pair of images in neither are ignored.
  ModelMergeStep step = MergeThroughMatches(
      other, {RowPair(2, 3), RowPair(5, 10)}, {}, &model);
  EXPECT_FALSE(step.merged);
  EXPECT_EQ(step.num_pairs, 0u);
  EXPECT_EQ(step.num_correspondences, 0u);
  // Fewer matched points than min_inliers.
  ModelMergeOptions options;
  options.min_inliers = 8;
  step = MergeThroughMatches(other, {RowPair(4, 6, 0, 7)}, options, &model);
  EXPECT_FALSE(step.merged);
  EXPECT_EQ(step.num_correspondences, 7u);
  EXPECT_EQ(model.NumRegImages(), 4u);
  // Keypoints without a 3D point give no correspondence.
  Reconstruction sparse = other;
  for (auto& [id, image] : sparse.images) {
    for (int k = 0; k < kNumPoints / 2; ++k) {
      image.points2D[k].point3D_id = kInvalidPoint3DId;
    }
  }
  for (int k = 0; k < kNumPoints / 2; ++k) sparse.points3D.erase(1001 + k);
  step = MergeThroughMatches(sparse, {RowPair(4, 6)}, {}, &model);
  EXPECT_TRUE(step.merged);
  EXPECT_EQ(step.num_correspondences, static_cast<size_t>(kNumPoints / 2));
  ExpectRowPoses(model);
  ExpectConsistentTracks(model);
}

TEST(RemoveImages, DropsObservationsAndPointsLeftWithOne) {
  Reconstruction model = RowModel(1, 5, Sim3d());
  // Point 1 is seen by images 1 and 2 only.
  for (int i = 3; i <= 5; ++i) {
    model.images.at(i).points2D[0].point3D_id = kInvalidPoint3DId;
  }
  model.points3D.at(1).track.resize(2);
  AddSingleCameraRigs(&model);
  RemoveImages({2, 3, 99}, &model);
  EXPECT_EQ(ImageIds(model), (std::vector<ImageId>{1, 4, 5}));
  EXPECT_EQ(model.points3D.count(1), 0u);
  EXPECT_EQ(model.images.at(1).points2D[0].point3D_id, kInvalidPoint3DId);
  EXPECT_EQ(model.NumPoints3D(), static_cast<size_t>(kNumPoints - 1));
  for (const auto& [pid, point] : model.points3D) {
    EXPECT_EQ(point.track.size(), 3u) << pid;
  }
  ExpectConsistentTracks(model);
  ASSERT_TRUE(model.frames.has_value());
  std::vector<uint32_t> frames;
  for (const Frame& f : *model.frames) frames.push_back(f.frame_id);
  EXPECT_EQ(frames, (std::vector<uint32_t>{1, 4, 5}));
}

TEST(RemoveImages, OnlyCameraDataMakeAFrameIncomplete) {
  Reconstruction model = RowModel(1, 3, Sim3d());
  AddSingleCameraRigs(&model);
  // Frame 2 also records an IMU whose data id is 3: image 3 is still a
  // frame of its own, and removing image 2 removes frame 2 with its IMU.
  (*model.frames)[1].data.push_back({SensorId{SensorType::kImu, 1}, 3});
  RemoveImages({2}, &model);
  EXPECT_EQ(ImageIds(model), (std::vector<ImageId>{1, 3}));
  std::vector<uint32_t> frames;
  for (const Frame& f : *model.frames) frames.push_back(f.frame_id);
  EXPECT_EQ(frames, (std::vector<uint32_t>{1, 3}));
}

TEST(RemoveImages, RefusesToSplitAFrameOfSeveralImages) {
  Reconstruction model = RowModel(1, 3, Sim3d());
  AddSingleCameraRigs(&model);
  (*model.frames)[0].data.push_back({SensorId{SensorType::kCamera, 2}, 2});
  const Reconstruction before = model;
  EXPECT_THROW(RemoveImages({2}, &model), Error);
  EXPECT_EQ(ImageIds(model), ImageIds(before));
  EXPECT_EQ(model.frames->size(), before.frames->size());
  EXPECT_EQ(model.NumObservations(), before.NumObservations());
}

TEST(UnmergedModels, WhatCouldNotJoinFitsBesideTheMergedModel) {
  // B shares image 10 with the base but holds it at a pose its points
  // disagree with, so it cannot join; C is too small; D shares nothing.
  Reconstruction b = RowModel(10, 16, SomeFrame(), 100);
  Rigid3d& pose = b.images.at(10).cam_from_world;
  pose = Rigid3d(Eigen::Quaterniond(
                     Eigen::AngleAxisd(0.35, Eigen::Vector3d::UnitX())),
                 Eigen::Vector3d::Zero()) *
         pose;
  const std::vector<Reconstruction> models = {
      RowModel(1, 10, Sim3d()), RowModel(30, 35, SomeFrame(), 300),
      RowModel(20, 21, SomeFrame(), 200), b};
  const ModelMergeResult result = MergeModels(models);
  ASSERT_EQ(result.base, 0u);
  ASSERT_EQ(result.NumMerged(), 0u);
  const std::vector<Reconstruction> unmerged = UnmergedModels(models, result);
  ASSERT_EQ(unmerged.size(), 3u);
  const std::vector<Reconstruction> left =
      DisjointModels(result.model, unmerged, 3);
  ASSERT_EQ(left.size(), 2u);
  // B came first (7 images before image 10 went), then D.
  EXPECT_EQ(ImageIds(left[0]),
            (std::vector<ImageId>{11, 12, 13, 14, 15, 16}));
  EXPECT_EQ(ImageIds(left[1]),
            (std::vector<ImageId>{30, 31, 32, 33, 34, 35}));
  for (const Reconstruction& m : left) ExpectConsistentTracks(m);
  // With a floor of 7 images neither is kept.
  EXPECT_EQ(DisjointModels(result.model, unmerged, 7).size(), 0u);
  // Nothing is left when everything merged.
  const std::vector<Reconstruction> chain = {RowModel(1, 5, Sim3d()),
                                             RowModel(5, 9, SomeFrame())};
  EXPECT_TRUE(UnmergedModels(chain, MergeModels(chain)).empty());
}

TEST(DisjointModels, LargerModelsKeepSharedImages) {
  const Reconstruction base = RowModel(1, 3, Sim3d());
  const std::vector<Reconstruction> models = {RowModel(3, 7, Sim3d(), 100),
                                              RowModel(10, 13, Sim3d(), 300),
                                              RowModel(6, 12, Sim3d(), 200)};
  // 6-12 comes first and keeps its images; 3-7 keeps 4 and 5; 10-13 keeps
  // only image 13, which observes no point once alone, so nothing.
  std::vector<Reconstruction> out = DisjointModels(base, models, 1);
  ASSERT_EQ(out.size(), 2u);
  EXPECT_EQ(ImageIds(out[0]), (std::vector<ImageId>{6, 7, 8, 9, 10, 11, 12}));
  EXPECT_EQ(ImageIds(out[1]), (std::vector<ImageId>{4, 5}));
  EXPECT_EQ(out[1].NumPoints3D(), static_cast<size_t>(kNumPoints));
  ExpectConsistentTracks(out[1]);
  out = DisjointModels(base, models, 3);
  ASSERT_EQ(out.size(), 1u);
  EXPECT_EQ(out[0].NumRegImages(), 7u);
}

TEST(ModelMergeOptions, CheckRejectsOutOfRangeValues) {
  ModelMergeOptions options;
  EXPECT_NO_THROW(options.Check());
  options.min_inliers = 0;
  EXPECT_THROW(options.Check(), Error);
  options = {};
  options.max_relative_error = 0;
  EXPECT_THROW(options.Check(), Error);
  options.max_relative_error = std::numeric_limits<double>::infinity();
  EXPECT_THROW(options.Check(), Error);
  options = {};
  options.min_inlier_ratio = 1.5;
  EXPECT_THROW(options.Check(), Error);
}

}  // namespace
}  // namespace hisfm
