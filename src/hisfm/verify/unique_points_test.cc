#include "hisfm/verify/unique_points.h"

#include <gtest/gtest.h>

#include "hisfm/io/database_writer.h"
#include "hisfm/util/error.h"
#include "hisfm/util/test_util.h"

namespace hisfm {
namespace {

constexpr int kNumKeypoints = 6;

// Images 1 to 3 are registered (at the origin, looking along +z): keypoint k
// of images 1 and 2 observes point k + 1, 5k m to the side and 10 m ahead,
// and so does keypoint k of image 3 except keypoint 5, which observes none.
// Image 4 is not in the model.
struct Scene {
  TempDir dir{"hisfm-unique-points"};
  Reconstruction model;
  std::vector<ImagePair> pairs;
};

using Matches = std::vector<FeatureMatch>;

void WriteScene(const std::vector<std::pair<ImagePair, Matches>>& pairs,
                Scene* scene) {
  DatabaseWriter writer(scene->dir / "database.db");
  DatabaseCamera camera;
  camera.camera_id = 1;
  camera.model_id = 0;
  camera.width = 100;
  camera.height = 100;
  camera.params = {100.0, 50.0, 50.0};
  writer.WriteCamera(camera);
  scene->model.cameras[1] = {1, 0, 100, 100, camera.params};
  for (ImageId k = 1; k <= 4; ++k) {
    const std::string name = "im" + std::to_string(k);
    writer.WriteImage({k, name, 1});
    Keypoints keypoints(kNumKeypoints, 2);
    Image image;
    image.image_id = k;
    image.camera_id = 1;
    image.name = name;
    for (int p = 0; p < kNumKeypoints; ++p) {
      keypoints.row(p) << 10.0f * p, 10.0f;
      const bool observes = !(k == 3 && p == 5);
      image.points2D.push_back(
          {Eigen::Vector2d(10.0 * p, 10.0),
           observes ? static_cast<Point3DId>(p + 1) : kInvalidPoint3DId});
    }
    writer.WriteKeypoints(k, keypoints);
    if (k != 4) scene->model.images[k] = image;
  }
  for (int p = 0; p < kNumKeypoints; ++p) {
    Point3D point;
    point.xyz = Eigen::Vector3d(5.0 * p, 0.0, 10.0);
    for (ImageId k : {1u, 2u, 3u}) {
      if (!(k == 3 && p == 5)) {
        point.track.push_back({k, static_cast<Point2DIdx>(p)});
      }
    }
    scene->model.points3D[p + 1] = point;
  }
  for (const auto& [pair, matches] : pairs) {
    TwoViewGeometry g;
    g.pair = pair;
    g.config = static_cast<int>(TwoViewConfig::kCalibrated);
    g.inlier_matches = matches;
    writer.WriteTwoViewGeometry(g);
    scene->pairs.push_back(pair);
  }
  writer.Close();
}

TEST(FindConfusingPoints, MarksBothPointsOfAMatchBetweenTwoPoints) {
  Scene scene;
  WriteScene(
      {
          // True matches only.
          {ImagePair(1, 2), {{0, 0}, {1, 1}, {2, 2}, {3, 3}, {4, 4}, {5, 5}}},
          // Keypoint 0 of image 1 matched to point 2's keypoint in image 3
          // (a doppelganger match), keypoint 2 truly.
          {ImagePair(1, 3), {{0, 1}, {2, 2}}},
          // Image 3's keypoint 5 observes no point.
          {ImagePair(2, 3), {{4, 5}}},
          // Image 4 is not registered: this pair is not read.
          {ImagePair(2, 4), {{3, 4}}},
      },
      &scene);
  const Database database(scene.dir / "database.db");
  const std::unordered_set<Point3DId> confusing =
      FindConfusingPoints(database, scene.pairs, scene.model);
  EXPECT_EQ(confusing, (std::unordered_set<Point3DId>{1, 2}));
}

TEST(FindConfusingPoints, TrueMatchesLeaveEveryPointUnique) {
  Scene scene;
  WriteScene({{ImagePair(1, 2), {{0, 0}, {3, 3}}},
              {ImagePair(2, 3), {{1, 1}, {4, 4}}}},
             &scene);
  const Database database(scene.dir / "database.db");
  EXPECT_TRUE(FindConfusingPoints(database, scene.pairs, scene.model).empty());
}

TEST(FindConfusingPoints, AnOutlierAmongTrueTiesLeavesAPointUnique) {
  Scene scene;
  WriteScene({{ImagePair(1, 2), {{0, 0}, {1, 1}}},
              {ImagePair(2, 3), {{0, 0}, {1, 1}}},
              {ImagePair(1, 3), {{0, 1}}}},
             &scene);
  const Database database(scene.dir / "database.db");
  // Points 1 and 2 have two ties to themselves and one elsewhere: not more
  // than 0.5 far ties per near tie (the default), so unique; more than 0.4.
  EXPECT_TRUE(FindConfusingPoints(database, scene.pairs, scene.model).empty());
  UniquePointOptions strict;
  strict.max_far_ties_per_near_tie = 0.4;
  EXPECT_EQ(FindConfusingPoints(database, scene.pairs, scene.model, strict),
            (std::unordered_set<Point3DId>{1, 2}));
}

TEST(FindConfusingPoints, ASplitTrackIsNotConfusing) {
  Scene scene;
  WriteScene({{ImagePair(1, 2), {{0, 1}}}}, &scene);
  // Point 2 moved within 0.1 of point 1's depth (10 m) of point 1: one
  // physical point that the mapper triangulated twice.
  scene.model.points3D[2].xyz = Eigen::Vector3d(0.5, 0.0, 10.0);
  const Database database(scene.dir / "database.db");
  EXPECT_TRUE(FindConfusingPoints(database, scene.pairs, scene.model).empty());
  scene.model.points3D[2].xyz = Eigen::Vector3d(2.0, 0.0, 10.0);
  EXPECT_EQ(FindConfusingPoints(database, scene.pairs, scene.model),
            (std::unordered_set<Point3DId>{1, 2}));
}

TEST(FindConfusingPoints, RejectsBadOptions) {
  UniquePointOptions options;
  options.max_relative_distance = 0.0;
  EXPECT_THROW(options.Check(), Error);
  options = UniquePointOptions();
  options.max_far_ties_per_near_tie = -1.0;
  EXPECT_THROW(options.Check(), Error);
}

TEST(FindConfusingPoints, AMatchPastTheModelsKeypointsThrows) {
  Scene scene;
  WriteScene({{ImagePair(1, 2), {{0, 0}}}}, &scene);
  scene.model.images[2].points2D.resize(0);
  const Database database(scene.dir / "database.db");
  EXPECT_THROW(FindConfusingPoints(database, scene.pairs, scene.model),
               Error);
}

}  // namespace
}  // namespace hisfm
