// Rigs and frames: their names, and the model files of COLMAP 3.12 and later
// that hold them (rigs.bin, frames.bin, rigs.txt, frames.txt), kept when
// hisfm rewrites a model.
#include "hisfm/io/rigs.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>

#include "hisfm/io/model.h"
#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"
#include "hisfm/util/test_util.h"

namespace fs = std::filesystem;

namespace hisfm {
namespace {

TEST(Rigs, SensorTypeNames) {
  for (const SensorType t :
       {SensorType::kCamera, SensorType::kImu, SensorType::kInvalid}) {
    EXPECT_EQ(SensorTypeFromName(SensorTypeName(t)), t);
  }
  EXPECT_EQ(SensorTypeName(SensorType::kCamera), "CAMERA");
  EXPECT_THROW(SensorTypeFromName("LIDAR"), Error);
}

// Two cameras on one rig (the second 0.5 to the right), two frames of it.
Reconstruction RigModel() {
  Reconstruction model;
  for (CameraId id : {1u, 2u}) {
    Camera camera;
    camera.camera_id = id;
    camera.model_id = 0;
    camera.width = 640;
    camera.height = 480;
    camera.params = {500, 320, 240};
    model.cameras[id] = camera;
  }
  const Rigid3d cam2_from_rig(Eigen::Quaterniond::Identity(),
                              Eigen::Vector3d(-0.5, 0, 0));
  Rig rig;
  rig.rig_id = 1;
  rig.ref_sensor = SensorId{SensorType::kCamera, 1};
  rig.sensors.push_back({SensorId{SensorType::kCamera, 2}, cam2_from_rig});
  Rig lonely;  // A rig without a sensor pose, and one without sensors.
  lonely.rig_id = 7;
  lonely.ref_sensor = SensorId{SensorType::kCamera, 2};
  lonely.sensors.push_back({SensorId{SensorType::kImu, 1}, std::nullopt});
  Rig empty;
  empty.rig_id = 3;
  model.rigs = std::vector<Rig>{rig, lonely, empty};
  model.frames = std::vector<Frame>();
  ImageId next_image = 1;
  for (uint32_t f : {4u, 2u}) {
    Frame frame;
    frame.frame_id = f;
    frame.rig_id = 1;
    frame.rig_from_world =
        Rigid3d(Eigen::Quaterniond(Eigen::AngleAxisd(0.1 * f,
                                                     Eigen::Vector3d::UnitY())),
                Eigen::Vector3d(f, 0.25, -1.0 / 3));
    for (CameraId c : {1u, 2u}) {
      Image image;
      image.image_id = next_image++;
      image.camera_id = c;
      image.name = StrCat("cam", c, "/", f, ".jpg");
      image.cam_from_world =
          (c == 1 ? Rigid3d() : cam2_from_rig) * *frame.rig_from_world;
      model.images[image.image_id] = image;
      frame.data.push_back({SensorId{SensorType::kCamera, c}, image.image_id});
    }
    model.frames->push_back(frame);
  }
  return model;
}

void ExpectSameRigsAndFrames(const Reconstruction& a, const Reconstruction& b) {
  ASSERT_TRUE(b.rigs.has_value());
  ASSERT_TRUE(b.frames.has_value());
  ASSERT_EQ(a.rigs->size(), b.rigs->size());
  for (const Rig& ra : *a.rigs) {
    const auto rb = std::find_if(b.rigs->begin(), b.rigs->end(),
                                 [&](const Rig& r) { return r.rig_id == ra.rig_id; });
    ASSERT_NE(rb, b.rigs->end());
    EXPECT_EQ(ra.ref_sensor.has_value(), rb->ref_sensor.has_value());
    if (ra.ref_sensor) {
      EXPECT_EQ(*ra.ref_sensor, *rb->ref_sensor);
    }
    ASSERT_EQ(ra.sensors.size(), rb->sensors.size());
    for (size_t k = 0; k < ra.sensors.size(); ++k) {
      EXPECT_EQ(ra.sensors[k].sensor, rb->sensors[k].sensor);
      EXPECT_EQ(ra.sensors[k].sensor_from_rig.has_value(),
                rb->sensors[k].sensor_from_rig.has_value());
    }
  }
  ASSERT_EQ(a.frames->size(), b.frames->size());
  for (const Frame& fa : *a.frames) {
    const auto fb =
        std::find_if(b.frames->begin(), b.frames->end(),
                     [&](const Frame& f) { return f.frame_id == fa.frame_id; });
    ASSERT_NE(fb, b.frames->end());
    EXPECT_EQ(fa.rig_id, fb->rig_id);
    EXPECT_TRUE(fa.rig_from_world->translation.isApprox(
        fb->rig_from_world->translation, 1e-15));
    EXPECT_NEAR(fa.rig_from_world->rotation.angularDistance(
                    fb->rig_from_world->rotation),
                0, 1e-15);
    ASSERT_EQ(fa.data.size(), fb->data.size());
    for (size_t k = 0; k < fa.data.size(); ++k) {
      EXPECT_EQ(fa.data[k].sensor, fb->data[k].sensor);
      EXPECT_EQ(fa.data[k].data_id, fb->data[k].data_id);
    }
  }
}

TEST(Rigs, ModelFilesKeepRigsAndFrames) {
  TempDir tmp;
  const Reconstruction model = RigModel();
  fs::create_directories(tmp / "bin");
  WriteModelBinary(model, tmp / "bin");
  ASSERT_TRUE(fs::exists(tmp / "bin/rigs.bin"));
  ASSERT_TRUE(fs::exists(tmp / "bin/frames.bin"));
  const Reconstruction read = ReadModel(tmp / "bin");
  ExpectSameRigsAndFrames(model, read);
  // Read and written again: byte-identical, rigs and frames included.
  fs::create_directories(tmp / "bin2");
  WriteModelBinary(read, tmp / "bin2");
  for (const char* file : {"rigs.bin", "frames.bin", "images.bin"}) {
    EXPECT_EQ(ReadTextFile(tmp / "bin" + "/" + file),
              ReadTextFile(tmp / "bin2" + "/" + file))
        << file;
  }
  // Text, by increasing id as COLMAP writes them, and back.
  fs::create_directories(tmp / "txt");
  WriteModelText(read, tmp / "txt");
  const std::string rigs = ReadTextFile(tmp / "txt/rigs.txt");
  EXPECT_NE(rigs.find("# Number of rigs: 3\n1 2 CAMERA 1 CAMERA 2 1 1 0 0 0 "
                      "-0.5 0 0\n3 0\n7 2 CAMERA 2 IMU 1 0\n"),
            std::string::npos)
      << rigs;
  const std::string frames = ReadTextFile(tmp / "txt/frames.txt");
  EXPECT_NE(frames.find("# Number of frames: 2\n2 1 "), std::string::npos)
      << frames;
  EXPECT_NE(frames.find(" 2 CAMERA 1 3 CAMERA 2 4\n4 1 "), std::string::npos)
      << frames;
  ExpectSameRigsAndFrames(model, ReadModel(tmp / "txt"));
}

TEST(Rigs, ModelsWithoutThemWriteNone) {
  TempDir tmp;
  Reconstruction model = RigModel();
  model.rigs.reset();
  model.frames.reset();
  WriteModelBinary(model, tmp.path());
  EXPECT_FALSE(fs::exists(tmp / "rigs.bin"));
  EXPECT_FALSE(fs::exists(tmp / "frames.bin"));
  EXPECT_FALSE(ReadModel(tmp.path()).rigs.has_value());
}

TEST(Rigs, MalformedFilesAreOneLineErrors) {
  TempDir tmp;
  WriteModelBinary(RigModel(), tmp.path());
  const std::string frames = ReadTextFile(tmp / "frames.bin");
  WriteFileAtomically(tmp / "frames.bin", frames.substr(0, frames.size() - 3));
  try {
    ReadModel(tmp.path());
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("frames.bin"), std::string::npos);
    EXPECT_EQ(std::string(e.what()).find('\n'), std::string::npos);
  }
  TempDir txt;
  WriteModelText(RigModel(), txt.path());
  WriteFileAtomically(txt / "rigs.txt", "1 2 CAMERA 1 LIDAR 2 0\n");
  try {
    ReadModel(txt.path());
    FAIL() << "no error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("rigs.txt line 1"), std::string::npos)
        << e.what();
  }
}

}  // namespace
}  // namespace hisfm
