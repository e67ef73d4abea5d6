#include "hisfm/io/model_validation.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <functional>
#include <limits>

#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"
#include "hisfm/util/test_util.h"

namespace fs = std::filesystem;

namespace hisfm {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kInf = std::numeric_limits<double>::infinity();

// A valid model: one camera, three images of four 2D points each, four 3D
// points seen by every image (2D point k observes point 10 + k).
Reconstruction ValidModel() {
  Reconstruction model;
  Camera camera;
  camera.camera_id = 1;
  camera.model_id = 2;  // SIMPLE_RADIAL
  camera.width = 640;
  camera.height = 480;
  camera.params = {500, 320, 240, 0.01};
  model.cameras[1] = camera;
  for (ImageId image_id = 1; image_id <= 3; ++image_id) {
    Image image;
    image.image_id = image_id;
    image.camera_id = 1;
    image.name = "img" + std::to_string(image_id) + ".jpg";
    image.cam_from_world.translation = Eigen::Vector3d(image_id, 0, 0);
    for (int k = 0; k < 4; ++k) {
      Point2D point;
      point.xy = Eigen::Vector2d(100 + k, 200);
      point.point3D_id = 10 + k;
      image.points2D.push_back(point);
    }
    model.images[image_id] = image;
  }
  for (Point3DId id = 10; id < 14; ++id) {
    Point3D point;
    point.xyz = Eigen::Vector3d(0, 0, 5 + id);
    point.error = 0.5;
    for (ImageId image_id = 1; image_id <= 3; ++image_id) {
      point.track.push_back({image_id, static_cast<Point2DIdx>(id - 10)});
    }
    model.points3D[id] = point;
  }
  return model;
}

// The one problem of the valid model changed by `change`.
ModelProblem OneProblem(const std::function<void(Reconstruction*)>& change) {
  Reconstruction model = ValidModel();
  change(&model);
  const std::vector<ModelProblem> problems = ValidateModel(model);
  EXPECT_EQ(problems.size(), 1u);
  if (problems.empty()) return {};
  return problems[0];
}

TEST(ModelValidation, ValidModelHasNoProblems) {
  EXPECT_TRUE(ValidateModel(ValidModel()).empty());
  EXPECT_NO_THROW(RequireValidModel(ValidModel(), "m"));
}

TEST(ModelValidation, NonFinitePoses) {
  ModelProblem p = OneProblem([](Reconstruction* m) {
    m->images[2].cam_from_world.rotation.w() = kNaN;
  });
  EXPECT_EQ(p.file, "images");
  EXPECT_EQ(p.id, "image 2");
  EXPECT_NE(p.message.find("is not a rotation"), std::string::npos);
  p = OneProblem([](Reconstruction* m) {
    m->images[2].cam_from_world.rotation.coeffs().setZero();
  });
  EXPECT_EQ(FormatModelProblem(p),
            "images, image 2: rotation quaternion (0, 0, 0, 0) is not a "
            "rotation");
  p = OneProblem([](Reconstruction* m) {
    m->images[3].cam_from_world.translation.y() = kInf;
  });
  EXPECT_EQ(FormatModelProblem(p),
            "images, image 3: translation (3, inf, 0) is not finite");
}

TEST(ModelValidation, TracksNameImagesAndTheirPoints) {
  ModelProblem p = OneProblem(
      [](Reconstruction* m) { m->points3D[11].track[1].image_id = 9; });
  EXPECT_EQ(FormatModelProblem(p),
            "points3D, point 11: track element 1 names image 9, which is "
            "not in the model");
  p = OneProblem(
      [](Reconstruction* m) { m->points3D[12].track[2].point2D_idx = 4; });
  EXPECT_EQ(FormatModelProblem(p),
            "points3D, point 12: track element 2 names point2D 4 of image 3, "
            "which has 4");
  p = OneProblem(
      [](Reconstruction* m) { m->points3D[12].track[0].point2D_idx = 3; });
  EXPECT_EQ(FormatModelProblem(p),
            "points3D, point 12: track element 0 names point2D 3 of image 1, "
            "which observes point 13");
  Reconstruction model = ValidModel();
  model.points3D.erase(13);
  const std::vector<ModelProblem> problems = ValidateModel(model);
  ASSERT_EQ(problems.size(), 3u) << "one for each image";
  EXPECT_EQ(FormatModelProblem(problems[0]),
            "images, image 1: point2D 3 observes point 13, which is not in "
            "points3D");
}

TEST(ModelValidation, NonFinitePointsAndCameras) {
  ModelProblem p =
      OneProblem([](Reconstruction* m) { m->points3D[10].xyz.x() = kNaN; });
  EXPECT_EQ(p.id, "point 10");
  EXPECT_NE(p.message.find("not finite"), std::string::npos);
  p = OneProblem([](Reconstruction* m) { m->points3D[10].error = kInf; });
  EXPECT_EQ(p.id, "point 10");
  p = OneProblem([](Reconstruction* m) { m->cameras[1].params[3] = kNaN; });
  EXPECT_EQ(FormatModelProblem(p), "cameras, camera 1: parameter 3 is nan");
  p = OneProblem([](Reconstruction* m) { m->cameras[1].params[0] = -5; });
  EXPECT_EQ(FormatModelProblem(p),
            "cameras, camera 1: focal length -5 is not positive");
  p = OneProblem([](Reconstruction* m) { m->cameras[1].width = 0; });
  EXPECT_EQ(FormatModelProblem(p),
            "cameras, camera 1: size 0 x 480 is not a positive image size");
  p = OneProblem([](Reconstruction* m) { m->cameras[1].params.pop_back(); });
  EXPECT_EQ(FormatModelProblem(p),
            "cameras, camera 1: model id 2 with 3 parameters");
  p = OneProblem(
      [](Reconstruction* m) { m->images[1].points2D[2].xy.y() = kNaN; });
  EXPECT_EQ(FormatModelProblem(p), "images, image 1: point2D 2 is not finite");
}

TEST(ModelValidation, NamesAreUniqueAndOneLine) {
  ModelProblem p =
      OneProblem([](Reconstruction* m) { m->images[3].name = "img1.jpg"; });
  EXPECT_EQ(FormatModelProblem(p),
            "images, image 3: name 'img1.jpg' is also the name of image 1");
  p = OneProblem([](Reconstruction* m) { m->images[3].name = "a\nb"; });
  EXPECT_NE(p.message.find("line break"), std::string::npos);
  p = OneProblem([](Reconstruction* m) { m->images[3].name = " c.jpg"; });
  EXPECT_EQ(FormatModelProblem(p),
            "images, image 3: name begins or ends with a space");
  p = OneProblem([](Reconstruction* m) { m->images[3].camera_id = 7; });
  EXPECT_EQ(FormatModelProblem(p),
            "images, image 3: refers to camera 7, which is not in the model");
}

TEST(ModelValidation, AllProblemsOrALimit) {
  Reconstruction model = ValidModel();
  model.cameras[1].width = 0;
  model.images[1].cam_from_world.translation.x() = kNaN;
  model.points3D[10].xyz.z() = kInf;
  EXPECT_EQ(ValidateModel(model).size(), 3u);
  ModelValidationOptions options;
  options.max_problems = 2;
  const std::vector<ModelProblem> first = ValidateModel(model, options);
  ASSERT_EQ(first.size(), 2u);
  EXPECT_EQ(first[0].file, "cameras");
  EXPECT_EQ(first[1].file, "images");
  options.max_problems = -1;
  EXPECT_THROW(options.Check(), Error);
}

// The readers refuse what the checks find; the files stay as they were.
TEST(ModelValidation, ReadersRefuseInvalidModels) {
  TempDir tmp;
  Reconstruction model = ValidModel();
  model.points3D[12].track[1].point2D_idx = 1000;
  fs::create_directories(tmp / "bin");
  fs::create_directories(tmp / "txt");
  WriteModelBinary(model, tmp / "bin");
  WriteModelText(model, tmp / "txt");
  for (const std::string& folder : {tmp / "bin", tmp / "txt"}) {
    const uint64_t before = FileFingerprint(folder + "/images.bin") ^
                            FileFingerprint(folder + "/points3D.txt");
    try {
      ReadModel(folder);
      FAIL() << "expected an error";
    } catch (const Error& e) {
      EXPECT_EQ(std::string(e.what()),
                "invalid COLMAP model " + folder +
                    ": points3D, point 12: track element 1 names point2D "
                    "1000 of image 2, which has 4 (hisfm check_model lists "
                    "every problem)");
    }
    EXPECT_EQ(ReadModelUnvalidated(folder).points3D.size(), 4u);
    EXPECT_EQ(FileFingerprint(folder + "/images.bin") ^
                  FileFingerprint(folder + "/points3D.txt"),
              before);
  }
  EXPECT_THROW(ReadModelBinary(tmp / "bin"), Error);
  EXPECT_THROW(ReadModelText(tmp / "txt"), Error);
}

TEST(ModelValidation, ReferenceModelsAreValid) {
  for (const char* scene : {"books", "cup", "oats"}) {
    const std::string path =
        SharedDataPath(std::string("yan2017/") + scene, "reference");
    if (path.empty()) continue;
    EXPECT_TRUE(ValidateModel(ReadModelUnvalidated(path)).empty()) << scene;
  }
}

}  // namespace
}  // namespace hisfm
