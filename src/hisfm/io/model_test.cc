#include "hisfm/io/model.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <random>

#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"
#include "hisfm/util/test_util.h"

namespace fs = std::filesystem;

namespace hisfm {
namespace {

const char* kModelFiles[] = {"cameras", "images", "points3D"};

std::string ReferenceModel(const std::string& scene) {
  return SharedDataPath("yan2017/" + scene, "reference");
}

void ExpectFilesEqual(const std::string& a, const std::string& b) {
  const std::string da = ReadTextFile(a);
  const std::string db = ReadTextFile(b);
  ASSERT_EQ(da.size(), db.size()) << a << " vs " << b;
  EXPECT_TRUE(da == db) << a << " and " << b << " differ";
}

// Runs `colmap model_converter` from `input` into a new folder `output`.
void ColmapConvert(const std::string& input, const std::string& output,
                   const std::string& type) {
  fs::create_directories(output);
  ASSERT_EQ(RunShell("colmap model_converter --input_path '" + input +
                     "' --output_path '" + output + "' --output_type " +
                     type),
            0)
      << "colmap model_converter failed on " << input;
}

// Exact equality of two models' contents (file_order aside).
void ExpectModelsEqual(const Reconstruction& a, const Reconstruction& b,
                       double rotation_tolerance = 0.0) {
  ASSERT_EQ(a.cameras.size(), b.cameras.size());
  for (const auto& [id, camera] : a.cameras) {
    const Camera& other = b.cameras.at(id);
    EXPECT_EQ(camera.camera_id, other.camera_id);
    EXPECT_EQ(camera.model_id, other.model_id);
    EXPECT_EQ(camera.width, other.width);
    EXPECT_EQ(camera.height, other.height);
    EXPECT_EQ(camera.params, other.params);
  }
  ASSERT_EQ(a.images.size(), b.images.size());
  for (const auto& [id, image] : a.images) {
    const Image& other = b.images.at(id);
    EXPECT_EQ(image.image_id, other.image_id);
    EXPECT_EQ(image.camera_id, other.camera_id);
    EXPECT_EQ(image.name, other.name);
    EXPECT_LE((image.cam_from_world.rotation.coeffs() -
               other.cam_from_world.rotation.coeffs())
                  .lpNorm<Eigen::Infinity>(),
              rotation_tolerance);
    EXPECT_EQ(image.cam_from_world.translation,
              other.cam_from_world.translation);
    ASSERT_EQ(image.points2D.size(), other.points2D.size());
    for (size_t i = 0; i < image.points2D.size(); ++i) {
      EXPECT_EQ(image.points2D[i].xy, other.points2D[i].xy);
      EXPECT_EQ(image.points2D[i].point3D_id, other.points2D[i].point3D_id);
    }
  }
  ASSERT_EQ(a.points3D.size(), b.points3D.size());
  for (const auto& [id, point] : a.points3D) {
    const Point3D& other = b.points3D.at(id);
    EXPECT_EQ(point.xyz, other.xyz);
    EXPECT_EQ(point.color, other.color);
    EXPECT_EQ(point.error, other.error);
    ASSERT_EQ(point.track.size(), other.track.size());
    for (size_t i = 0; i < point.track.size(); ++i) {
      EXPECT_EQ(point.track[i].image_id, other.track[i].image_id);
      EXPECT_EQ(point.track[i].point2D_idx, other.track[i].point2D_idx);
    }
  }
}

// A small model with every camera model, unobserved keypoints, a point
// without track, an image without keypoints and non-trivial poses.
Reconstruction MakeSyntheticModel() {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uniform(-10.0, 10.0);
  Reconstruction model;
  for (int model_id = 0; model_id <= 10; ++model_id) {
    Camera camera;
    camera.camera_id = static_cast<CameraId>(3 * model_id + 1);
    camera.model_id = model_id;
    camera.width = 640 + model_id;
    camera.height = 480;
    for (int p = 0; p < CameraModelNumParams(model_id); ++p) {
      camera.params.push_back(uniform(rng) / 3.0);
    }
    // Focal lengths are positive (the readers check it).
    for (int p = 0; p < CameraModelNumFocalLengths(model_id); ++p) {
      camera.params[p] = std::abs(camera.params[p]) + 1.0;
    }
    model.cameras[camera.camera_id] = camera;
  }
  for (ImageId image_id = 5; image_id < 40; image_id += 3) {
    Image image;
    image.image_id = image_id;
    image.camera_id = static_cast<CameraId>(3 * (image_id % 11) + 1);
    image.name = "dir/img_" + std::to_string(image_id) + ".jpg";
    image.cam_from_world.rotation =
        Eigen::Quaterniond(uniform(rng), uniform(rng), uniform(rng),
                           uniform(rng))
            .normalized();
    image.cam_from_world.translation =
        Eigen::Vector3d(uniform(rng), uniform(rng), uniform(rng));
    const int num_points = image_id == 8 ? 0 : 20;
    for (int i = 0; i < num_points; ++i) {
      Point2D point;
      point.xy = Eigen::Vector2d(uniform(rng) + 100, uniform(rng) + 50);
      point.point3D_id = i % 3 == 0 ? kInvalidPoint3DId : 100 + i;
      image.points2D.push_back(point);
    }
    model.images[image_id] = image;
  }
  for (Point3DId point3D_id = 100; point3D_id < 120; ++point3D_id) {
    Point3D point;
    point.xyz = Eigen::Vector3d(uniform(rng), uniform(rng), uniform(rng));
    point.color = Eigen::Matrix<uint8_t, 3, 1>(point3D_id, 255, 0);
    point.error = point3D_id == 101 ? -1.0 : uniform(rng) + 10.0;
    // A track names 2D points that observe its point (every third 2D point
    // observes none).
    if (point3D_id != 104 && (point3D_id - 100) % 3 != 0) {
      for (ImageId image_id = 5; image_id < 40; image_id += 6) {
        if (image_id == 8) continue;
        point.track.push_back(
            {image_id, static_cast<Point2DIdx>(point3D_id - 100)});
      }
    }
    model.points3D[point3D_id] = point;
  }
  return model;
}

TEST(CameraModels, TableMatchesColmap) {
  const std::vector<std::pair<std::string, int>> expected = {
      {"SIMPLE_PINHOLE", 3}, {"PINHOLE", 4},         {"SIMPLE_RADIAL", 4},
      {"RADIAL", 5},         {"OPENCV", 8},          {"OPENCV_FISHEYE", 8},
      {"FULL_OPENCV", 12},   {"FOV", 5},             {"SIMPLE_RADIAL_FISHEYE", 4},
      {"RADIAL_FISHEYE", 5}, {"THIN_PRISM_FISHEYE", 12},
      // COLMAP 3.11, 4.0 and 4.1 (src/colmap/sensor/models.h).
      {"RAD_TAN_THIN_PRISM_FISHEYE", 16}, {"SIMPLE_DIVISION", 4},
      {"DIVISION", 5}, {"SIMPLE_FISHEYE", 3}, {"FISHEYE", 4}, {"EUCM", 6},
      {"EQUIRECTANGULAR", 2}};
  for (int id = 0; id < static_cast<int>(expected.size()); ++id) {
    EXPECT_EQ(CameraModelIdToName(id), expected[id].first);
    EXPECT_EQ(CameraModelNumParams(id), expected[id].second);
    EXPECT_EQ(CameraModelNameToId(expected[id].first), id);
  }
  EXPECT_EQ(CameraModelNumParams(18), -1);
  EXPECT_EQ(CameraModelNumFocalLengths(17), 0);
  EXPECT_EQ(CameraModelIdToName(-1), "");
  EXPECT_EQ(CameraModelNameToId("PINHOLE "), -1);
}

TEST(Model, SyntheticBinaryRoundTripIsExact) {
  const Reconstruction model = MakeSyntheticModel();
  TempDir dir("hisfm-model");
  WriteModelBinary(model, dir.path());
  const Reconstruction read = ReadModel(dir.path());
  ExpectModelsEqual(model, read);
  // Written again in the order it was read: the same bytes.
  TempDir dir2("hisfm-model");
  WriteModelBinary(read, dir2.path());
  for (const char* file : kModelFiles) {
    ExpectFilesEqual(dir / (std::string(file) + ".bin"),
                     dir2 / (std::string(file) + ".bin"));
  }
  // No temporary files are left behind.
  size_t num_files = 0;
  for (const auto& entry : fs::directory_iterator(dir.path())) {
    (void)entry;
    ++num_files;
  }
  EXPECT_EQ(num_files, 3u);
}

TEST(Model, SyntheticTextRoundTrip) {
  const Reconstruction model = MakeSyntheticModel();
  TempDir dir("hisfm-model");
  WriteModelText(model, dir.path());
  const Reconstruction read = ReadModel(dir.path());
  // Text keeps 17 significant digits: all values survive exactly, except
  // that quaternions are re-normalized as COLMAP does.
  ExpectModelsEqual(model, read, 1e-15);
  EXPECT_EQ(read.MeanTrackLength(), model.MeanTrackLength());
  EXPECT_EQ(read.NumObservations(), model.NumObservations());
  EXPECT_EQ(read.MeanReprojectionError(), model.MeanReprojectionError());
  // Statistics: points 100..119 except 104 have 6 observations; 101 has no
  // error.
  EXPECT_EQ(model.NumObservations(), 12u * 6u);
  EXPECT_DOUBLE_EQ(model.MeanTrackLength(), 12.0 * 6.0 / 20.0);
  ASSERT_NE(model.FindImageWithName("dir/img_11.jpg"), nullptr);
  EXPECT_EQ(model.FindImageWithName("dir/img_11.jpg")->image_id, 11u);
  EXPECT_EQ(model.FindImageWithName("img_11.jpg"), nullptr);
}

TEST(Model, SyntheticTextMatchesColmap) {
  if (!ColmapAvailable()) GTEST_SKIP() << "colmap is not on PATH";
  const Reconstruction model = MakeSyntheticModel();
  TempDir dir("hisfm-model");
  const std::string bin = dir / "bin", ours = dir / "ours",
                    theirs = dir / "theirs";
  fs::create_directories(bin);
  fs::create_directories(ours);
  WriteModelBinary(model, bin);
  WriteModelText(ReadModel(bin), ours);
  ColmapConvert(bin, theirs, "TXT");
  for (const char* file : kModelFiles) {
    ExpectFilesEqual(ours + "/" + file + ".txt",
                     theirs + "/" + file + ".txt");
  }
  // Writing text straight from memory gives the same bytes as going through
  // the binary files.
  const std::string direct = dir / "direct";
  fs::create_directories(direct);
  WriteModelText(model, direct);
  for (const char* file : kModelFiles) {
    ExpectFilesEqual(direct + "/" + file + ".txt",
                     theirs + "/" + file + ".txt");
  }
}

class ReferenceModelTest : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    reference_ = ReferenceModel(GetParam());
    if (reference_.empty()) {
      GTEST_SKIP() << "shared data absent: no yan2017/" << GetParam()
                   << "/reference under " << SharedDataDir();
    }
  }
  std::string reference_;
};

TEST_P(ReferenceModelTest, BinaryRoundTripIsByteIdentical) {
  const Reconstruction model = ReadModelBinary(reference_);
  EXPECT_GT(model.NumRegImages(), 10u);
  EXPECT_GT(model.NumPoints3D(), 1000u);
  TempDir dir("hisfm-model");
  WriteModelBinary(model, dir.path());
  for (const char* file : kModelFiles) {
    ExpectFilesEqual(reference_ + "/" + file + ".bin",
                     dir / (std::string(file) + ".bin"));
  }
}

TEST_P(ReferenceModelTest, TextMatchesColmapModelConverter) {
  if (!ColmapAvailable()) GTEST_SKIP() << "colmap is not on PATH";
  TempDir dir("hisfm-model");
  const std::string theirs = dir / "theirs", ours = dir / "ours";
  ColmapConvert(reference_, theirs, "TXT");
  fs::create_directories(ours);
  WriteModelText(ReadModel(reference_), ours);
  for (const char* file : kModelFiles) {
    ExpectFilesEqual(theirs + "/" + file + ".txt",
                     ours + "/" + file + ".txt");
  }
}

TEST_P(ReferenceModelTest, TextToBinaryToTextRoundTrip) {
  TempDir dir("hisfm-model");
  const std::string text = dir / "text", bin = dir / "bin",
                    text2 = dir / "text2";
  for (const std::string& folder : {text, bin, text2}) {
    fs::create_directories(folder);
  }
  const Reconstruction reference = ReadModel(reference_);
  WriteModelText(reference, text);
  const Reconstruction from_text = ReadModel(text);
  ExpectModelsEqual(reference, from_text, 1e-15);
  // Binary files keep the values read from text exactly, and their order.
  WriteModelBinary(from_text, bin);
  const Reconstruction from_bin = ReadModel(bin);
  ExpectModelsEqual(from_text, from_bin);
  EXPECT_EQ(from_text.file_order.images, from_bin.file_order.images);
  EXPECT_EQ(from_text.file_order.points3D, from_bin.file_order.points3D);
  WriteModelText(from_bin, text2);
  ExpectModelsEqual(from_text, ReadModel(text2), 1e-15);
  if (!ColmapAvailable()) GTEST_SKIP() << "colmap is not on PATH";
  // Text from a text model, and text from the binary written from it, are
  // what colmap makes of the same files.
  const std::string theirs = dir / "theirs", theirs2 = dir / "theirs2",
                    ours = dir / "ours";
  ColmapConvert(text, theirs, "TXT");
  ColmapConvert(bin, theirs2, "TXT");
  fs::create_directories(ours);
  WriteModelText(from_text, ours);
  for (const char* file : kModelFiles) {
    ExpectFilesEqual(theirs + "/" + file + ".txt", ours + "/" + file + ".txt");
    ExpectFilesEqual(theirs2 + "/" + file + ".txt",
                     text2 + "/" + file + ".txt");
  }
}

INSTANTIATE_TEST_SUITE_P(Yan2017, ReferenceModelTest,
                         ::testing::Values("cup", "books"));

// Expects ReadModel to throw an Error whose message names `file`.
void ExpectReadErrorNaming(const std::string& folder, const std::string& file) {
  try {
    ReadModel(folder);
    ADD_FAILURE() << "no error for " << file;
  } catch (const Error& e) {
    const std::string message = e.what();
    EXPECT_NE(message.find(file), std::string::npos) << message;
    EXPECT_EQ(message.find('\n'), std::string::npos) << message;
  }
}

TEST(Model, TruncatedBinaryFilesAreErrors) {
  const Reconstruction model = MakeSyntheticModel();
  TempDir dir("hisfm-model");
  WriteModelBinary(model, dir.path());
  for (const char* name : kModelFiles) {
    const std::string file = dir / (std::string(name) + ".bin");
    const std::string good = ReadTextFile(file);
    for (const size_t keep : {size_t{0}, size_t{5}, good.size() / 2,
                              good.size() - 1}) {
      WriteFileAtomically(file, good.substr(0, keep));
      ExpectReadErrorNaming(dir.path(), file);
    }
    WriteFileAtomically(file, good + "x");
    ExpectReadErrorNaming(dir.path(), file);
    WriteFileAtomically(file, good);
  }
  EXPECT_NO_THROW(ReadModel(dir.path()));
  // A huge announced count fails cleanly instead of allocating.
  const std::string file = dir / "points3D.bin";
  std::string data = ReadTextFile(file);
  const uint64_t huge = uint64_t{1} << 60;
  std::memcpy(&data[0], &huge, sizeof(huge));
  WriteFileAtomically(file, data);
  ExpectReadErrorNaming(dir.path(), file);
}

TEST(Model, MalformedTextFilesAreErrors) {
  const Reconstruction model = MakeSyntheticModel();
  TempDir dir("hisfm-model");
  WriteModelText(model, dir.path());
  const std::string images = dir / "images.txt";
  const std::string good = ReadTextFile(images);
  // Cut in the middle of a number on the last line.
  WriteFileAtomically(images, good.substr(0, good.size() - 20) + "x\n");
  ExpectReadErrorNaming(dir.path(), images);
  // Missing the POINTS2D line of the last image.
  const size_t last_line = good.rfind('\n', good.size() - 2);
  WriteFileAtomically(images, good.substr(0, last_line + 1));
  ExpectReadErrorNaming(dir.path(), images);
  WriteFileAtomically(images, good);
  EXPECT_NO_THROW(ReadModel(dir.path()));

  const std::string cameras = dir / "cameras.txt";
  WriteFileAtomically(cameras, "1 PINHOLE 10 10 1 2 3\n");
  ExpectReadErrorNaming(dir.path(), cameras);
  WriteFileAtomically(cameras, "1 NO_SUCH_MODEL 10 10 1 2 3\n");
  ExpectReadErrorNaming(dir.path(), cameras);
}

TEST(Model, MissingFilesAreErrors) {
  TempDir dir("hisfm-model");
  ExpectReadErrorNaming(dir / "nothing", dir / "nothing");
  ExpectReadErrorNaming(dir.path(), dir.path());
  WriteModelBinary(MakeSyntheticModel(), dir.path());
  fs::remove(dir / "points3D.bin");
  ExpectReadErrorNaming(dir.path(), dir / "points3D.bin");
  EXPECT_THROW(WriteModelBinary(MakeSyntheticModel(), dir / "nothing"), Error);
  EXPECT_THROW(WriteModelText(MakeSyntheticModel(), dir / "nothing"), Error);
}

TEST(Model, FindsNumberedModelFolders) {
  TempDir dir("hisfm-model");
  EXPECT_FALSE(HasModel(dir.path()));
  EXPECT_TRUE(NumberedModelFolders(dir.path()).empty());
  EXPECT_TRUE(NumberedModelFolders(dir / "missing").empty());
  // Models in 10, 2 and 0 (binary and text), a numbered folder without a
  // model, a named folder with one, and a numbered file.
  for (const std::string name : {"10", "2", "1", "sparse"}) {
    fs::create_directories(dir / name);
  }
  fs::create_directories(dir / "0");
  WriteModelBinary(MakeSyntheticModel(), dir / "10");
  WriteModelBinary(MakeSyntheticModel(), dir / "sparse");
  WriteModelText(MakeSyntheticModel(), dir / "2");
  WriteModelText(MakeSyntheticModel(), dir / "0");
  WriteFileAtomically(dir / "3", "not a folder\n");
  EXPECT_TRUE(HasModel(dir / "2"));
  EXPECT_TRUE(HasModel(dir / "10"));
  EXPECT_FALSE(HasModel(dir / "1"));
  EXPECT_EQ(NumberedModelFolders(dir.path()),
            (std::vector<std::string>{dir / "0", dir / "2", dir / "10"}));
  // ReadNumberedModels stops at the first missing number.
  EXPECT_EQ(ReadNumberedModels(dir.path()).size(), 1u);
}

TEST(Model, WritingFollowsFileOrder) {
  Reconstruction model = MakeSyntheticModel();
  model.file_order.points3D = {119, 100, 119, 5000, 110};
  TempDir dir("hisfm-model");
  WriteModelBinary(model, dir.path());
  const Reconstruction read = ReadModel(dir.path());
  // Listed ids first (repeats and unknown ids dropped), then the rest.
  std::vector<Point3DId> expected = {119, 100, 110};
  for (Point3DId id = 101; id < 119; ++id) {
    if (id != 110) expected.push_back(id);
  }
  EXPECT_EQ(read.file_order.points3D, expected);
  ExpectModelsEqual(model, read);
}

}  // namespace
}  // namespace hisfm
