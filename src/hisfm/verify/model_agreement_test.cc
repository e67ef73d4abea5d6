#include "hisfm/verify/model_agreement.h"

#include <gtest/gtest.h>

#include <map>

#include "hisfm/io/database_writer.h"
#include "hisfm/util/error.h"
#include "hisfm/util/test_util.h"

namespace hisfm {
namespace {

constexpr double kFocal = 800.0;
constexpr int kWidth = 1024, kHeight = 768;
// Facade points every 0.5 m along x (17 columns from x = -3 to 5) at three
// heights, 10 m in front of the cameras: a pattern that repeats every 2 m
// (4 columns) if the points look alike.
constexpr int kColumns = 17, kRows = 3;

int PointIndex(int column, int row) { return row * kColumns + column; }

Eigen::Vector3d PointXyz(int index) {
  return {-3.0 + 0.5 * (index % kColumns), 10.0, -1.0 + (index / kColumns)};
}

// Camera `k` stands at (k - 1, 0, 0) and looks along +y; camera 6 stands at
// (0, 0, 0) and looks the other way (it sees none of the facade).
Rigid3d CamFromWorld(int k) {
  Eigen::Matrix3d R;
  if (k == 6) {
    R << -1, 0, 0, 0, 0, -1, 0, -1, 0;
    return Rigid3d(Eigen::Quaterniond(R), Eigen::Vector3d::Zero());
  }
  R << 1, 0, 0, 0, 0, -1, 0, 1, 0;
  const Eigen::Vector3d center(k - 1.0, 0.0, 0.0);
  return Rigid3d(Eigen::Quaterniond(R), -(R * center));
}

Eigen::Vector2d Project(int k, int point) {
  const Eigen::Vector3d x = CamFromWorld(k) * PointXyz(point);
  return {kFocal * x.x() / x.z() + kWidth / 2.0,
          kFocal * x.y() / x.z() + kHeight / 2.0};
}

// Images 1 to 3 see every facade point as their keypoint of the same index;
// image 4 is not in the model. The pair (1, 2) matches the true points,
// (1, 3) a copy of the pattern 2 m to the right (a doppelganger: a shift
// along the baseline, so its matches still lie on the model's epipolar
// lines), (2, 3) has only three matches, (2, 4) has every match, and (3, 5)
// matches its lowest row to the copy and the two others truly (a pair of
// true and doppelganger matches).
struct Scene {
  TempDir dir{"hisfm-model-agreement"};
  Reconstruction model;
};

void WriteScene(Scene* scene) {
  DatabaseWriter writer(scene->dir / "database.db");
  DatabaseCamera camera;
  camera.camera_id = 1;
  camera.model_id = 1;
  camera.width = kWidth;
  camera.height = kHeight;
  camera.params = {kFocal, kFocal, kWidth / 2.0, kHeight / 2.0};
  writer.WriteCamera(camera);
  scene->model.cameras[1] = {1, 1, kWidth, kHeight, camera.params};
  const int num_points = kColumns * kRows;
  for (int k = 1; k <= 6; ++k) {
    writer.WriteImage({static_cast<ImageId>(k), "im" + std::to_string(k), 1});
    Keypoints keypoints(num_points, 2);
    Image image;
    image.image_id = k;
    image.camera_id = 1;
    image.name = "im" + std::to_string(k);
    image.cam_from_world = CamFromWorld(k);
    for (int p = 0; p < num_points; ++p) {
      const Eigen::Vector2d uv = Project(k, p);
      keypoints.row(p) << static_cast<float>(uv.x()), static_cast<float>(uv.y());
      image.points2D.push_back(
          {uv, k == 6 ? kInvalidPoint3DId : static_cast<Point3DId>(p + 1)});
    }
    writer.WriteKeypoints(k, keypoints);
    if (k != 4) scene->model.images[k] = image;
  }
  for (int p = 0; p < num_points; ++p) {
    Point3D point;
    point.xyz = PointXyz(p);
    for (ImageId k : {1u, 2u, 3u, 5u}) {
      point.track.push_back({k, static_cast<Point2DIdx>(p)});
    }
    scene->model.points3D[p + 1] = point;
  }
  // Rows below `shifted_rows` match the copy `shift` columns to the right.
  auto write = [&](ImageId a, ImageId b, int shift, int max_matches,
                   int shifted_rows = kRows) {
    TwoViewGeometry g;
    g.pair = ImagePair(a, b);
    g.config = static_cast<int>(TwoViewConfig::kCalibrated);
    for (int row = 0; row < kRows; ++row) {
      const int s = row < shifted_rows ? shift : 0;
      for (int column = 0; column + s < kColumns; ++column) {
        if (static_cast<int>(g.inlier_matches.size()) == max_matches) break;
        g.inlier_matches.push_back(
            {static_cast<Point2DIdx>(PointIndex(column, row)),
             static_cast<Point2DIdx>(PointIndex(column + s, row))});
      }
    }
    writer.WriteTwoViewGeometry(g);
  };
  write(1, 2, 0, 1000);
  write(1, 3, 4, 1000);
  write(2, 3, 0, 3);
  write(2, 4, 0, 1000);
  write(3, 5, 4, 1000, 1);
  write(1, 6, 0, 1000);
  writer.Close();
}

std::map<ImagePair, PairAgreement> Judge(const Scene& scene,
                                         const ModelAgreementOptions& options) {
  const Database db(scene.dir / "database.db");
  const std::vector<ImagePair> pairs = {ImagePair(1, 2), ImagePair(1, 3),
                                        ImagePair(2, 3), ImagePair(2, 4),
                                        ImagePair(3, 5), ImagePair(1, 6)};
  std::map<ImagePair, PairAgreement> by_pair;
  for (const PairAgreement& a :
       JudgePairsAgainstModel(db, pairs, scene.model, options)) {
    by_pair[a.pair] = a;
  }
  return by_pair;
}

TEST(ModelAgreement, TrueMatchesAgreeAndAShiftedPatternDoesNot) {
  Scene scene;
  WriteScene(&scene);
  const auto judged = Judge(scene, ModelAgreementOptions());
  ASSERT_EQ(judged.size(), 5u) << "the pair with image 4 is left out";

  const PairAgreement& truth = judged.at(ImagePair(1, 2));
  EXPECT_EQ(truth.num_testable, 2 * kColumns * kRows);
  EXPECT_EQ(truth.num_agreeing, truth.num_testable);
  EXPECT_TRUE(truth.judged);
  EXPECT_TRUE(truth.agrees);
  EXPECT_EQ(truth.agreeing_matches.size(), static_cast<size_t>(kColumns * kRows));

  // 2 m at 10 m depth is 160 pixels, far beyond 2% of the diagonal.
  const PairAgreement& doppelganger = judged.at(ImagePair(1, 3));
  EXPECT_EQ(doppelganger.num_testable, 2 * (kColumns - 4) * kRows);
  EXPECT_EQ(doppelganger.num_agreeing, 0);
  EXPECT_TRUE(doppelganger.judged);
  EXPECT_FALSE(doppelganger.agrees);
  EXPECT_TRUE(doppelganger.agreeing_matches.empty());

  // The true two thirds agree and are kept; the lowest row's copies are not.
  const PairAgreement& mixed = judged.at(ImagePair(3, 5));
  EXPECT_TRUE(mixed.agrees);
  ASSERT_EQ(mixed.agreeing_matches.size(), static_cast<size_t>(2 * kColumns));
  for (const FeatureMatch& m : mixed.agreeing_matches) {
    EXPECT_EQ(m.idx1, m.idx2);
    EXPECT_GE(m.idx1, static_cast<Point2DIdx>(kColumns));
  }

  // Image 6 looks away: its pair cannot agree and is left unjudged (its
  // matches are not read).
  const PairAgreement& away = judged.at(ImagePair(1, 6));
  EXPECT_EQ(away.num_testable, 0);
  EXPECT_FALSE(away.judged);
  EXPECT_FALSE(away.agrees);

  const PairAgreement& few = judged.at(ImagePair(2, 3));
  EXPECT_EQ(few.num_testable, 6);
  EXPECT_FALSE(few.judged);
  EXPECT_FALSE(few.agrees);
}

TEST(ModelAgreement, TheBoundsDecide) {
  Scene scene;
  WriteScene(&scene);
  ModelAgreementOptions loose;
  loose.max_transfer_error = 0.2;  // 256 pixels: the copy lands close enough
  EXPECT_TRUE(Judge(scene, loose).at(ImagePair(1, 3)).agrees);

  ModelAgreementOptions few_enough;
  few_enough.min_testable = 6;
  EXPECT_TRUE(Judge(scene, few_enough).at(ImagePair(2, 3)).agrees);

  ModelAgreementOptions bad;
  bad.max_transfer_error = 0.0;
  EXPECT_THROW(bad.Check(), Error);
  bad = ModelAgreementOptions();
  bad.min_agreeing_share = 2.0;
  EXPECT_THROW(bad.Check(), Error);
}

// A model whose keypoints do not match the database's is refused in one
// line rather than read past its end.
TEST(ModelAgreement, KeypointsPastTheModelAreAnError) {
  Scene scene;
  WriteScene(&scene);
  scene.model.images[2].points2D.resize(3);
  const Database db(scene.dir / "database.db");
  EXPECT_THROW(JudgePairsAgainstModel(db, {ImagePair(1, 2)}, scene.model,
                                      ModelAgreementOptions()),
               Error);
}

}  // namespace
}  // namespace hisfm
