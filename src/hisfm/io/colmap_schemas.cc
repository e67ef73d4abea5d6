#include "hisfm/io/colmap_schemas.h"

#include "hisfm/io/database.h"
#include "hisfm/util/error.h"

namespace hisfm {
namespace {

constexpr char kCameras[] =
    "CREATE TABLE IF NOT EXISTS cameras (camera_id INTEGER PRIMARY KEY "
    "AUTOINCREMENT NOT NULL, model INTEGER NOT NULL, width INTEGER NOT NULL, "
    "height INTEGER NOT NULL, params BLOB, prior_focal_length INTEGER NOT "
    "NULL);";
constexpr char kImages[] =
    "CREATE TABLE IF NOT EXISTS images (image_id INTEGER PRIMARY KEY "
    "AUTOINCREMENT NOT NULL, name TEXT NOT NULL UNIQUE, camera_id INTEGER NOT "
    "NULL, CONSTRAINT image_id_check CHECK(image_id >= 0 and image_id < "
    "2147483647), FOREIGN KEY(camera_id) REFERENCES cameras(camera_id));";
constexpr char kImageNameIndex[] =
    "CREATE UNIQUE INDEX IF NOT EXISTS index_name ON images(name);";
constexpr char kPosePriors310[] =
    "CREATE TABLE IF NOT EXISTS pose_priors (image_id INTEGER PRIMARY KEY NOT "
    "NULL, position BLOB, coordinate_system INTEGER NOT NULL, FOREIGN "
    "KEY(image_id) REFERENCES images(image_id) ON DELETE CASCADE);";
constexpr char kPosePriors311[] =
    "CREATE TABLE IF NOT EXISTS pose_priors (image_id INTEGER PRIMARY KEY NOT "
    "NULL, position BLOB, coordinate_system INTEGER NOT NULL, "
    "position_covariance BLOB, FOREIGN KEY(image_id) REFERENCES "
    "images(image_id) ON DELETE CASCADE);";
constexpr char kPosePriors40[] =
    "CREATE TABLE IF NOT EXISTS pose_priors (pose_prior_id INTEGER PRIMARY "
    "KEY NOT NULL, corr_data_id INTEGER NOT NULL, corr_sensor_id INTEGER NOT "
    "NULL, corr_sensor_type INTEGER NOT NULL, position BLOB, "
    "position_covariance BLOB, gravity BLOB, coordinate_system INTEGER NOT "
    "NULL);";
constexpr char kPosePriorIndex40[] =
    "CREATE UNIQUE INDEX IF NOT EXISTS pose_prior_data_assignment ON "
    "pose_priors(corr_data_id, corr_sensor_id, corr_sensor_type);";
constexpr char kRigs[] =
    "CREATE TABLE IF NOT EXISTS rigs (rig_id INTEGER PRIMARY KEY "
    "AUTOINCREMENT NOT NULL, ref_sensor_id INTEGER NOT NULL, ref_sensor_type "
    "INTEGER NOT NULL);";
constexpr char kRigIndex[] =
    "CREATE UNIQUE INDEX IF NOT EXISTS rig_ref_sensor_assignment ON "
    "rigs(ref_sensor_id, ref_sensor_type);";
constexpr char kRigSensors[] =
    "CREATE TABLE IF NOT EXISTS rig_sensors (rig_id INTEGER NOT NULL, "
    "sensor_id INTEGER NOT NULL, sensor_type INTEGER NOT NULL, "
    "sensor_from_rig BLOB, FOREIGN KEY(rig_id) REFERENCES rigs(rig_id) ON "
    "DELETE CASCADE);";
constexpr char kRigSensorIndex[] =
    "CREATE UNIQUE INDEX IF NOT EXISTS rig_sensor_assignment ON "
    "rig_sensors(sensor_id, sensor_type);";
constexpr char kFrames[] =
    "CREATE TABLE IF NOT EXISTS frames (frame_id INTEGER PRIMARY KEY "
    "AUTOINCREMENT NOT NULL, rig_id INTEGER NOT NULL, FOREIGN KEY(rig_id) "
    "REFERENCES rigs(rig_id) ON DELETE CASCADE);";
constexpr char kFrameData[] =
    "CREATE TABLE IF NOT EXISTS frame_data (frame_id INTEGER NOT NULL, "
    "data_id INTEGER NOT NULL, sensor_id INTEGER NOT NULL, sensor_type "
    "INTEGER NOT NULL, FOREIGN KEY(frame_id) REFERENCES frames(frame_id) ON "
    "DELETE CASCADE);";
constexpr char kFrameDataIndex[] =
    "CREATE UNIQUE INDEX IF NOT EXISTS frame_sensor_assignment ON "
    "frame_data(data_id, sensor_type);";
constexpr char kKeypoints[] =
    "CREATE TABLE IF NOT EXISTS keypoints (image_id INTEGER PRIMARY KEY NOT "
    "NULL, rows INTEGER NOT NULL, cols INTEGER NOT NULL, data BLOB, FOREIGN "
    "KEY(image_id) REFERENCES images(image_id) ON DELETE CASCADE);";
constexpr char kDescriptors[] =
    "CREATE TABLE IF NOT EXISTS descriptors (image_id INTEGER PRIMARY KEY NOT "
    "NULL, rows INTEGER NOT NULL, cols INTEGER NOT NULL, data BLOB, FOREIGN "
    "KEY(image_id) REFERENCES images(image_id) ON DELETE CASCADE);";
constexpr char kDescriptors40[] =
    "CREATE TABLE IF NOT EXISTS descriptors (image_id INTEGER PRIMARY KEY NOT "
    "NULL, type INTEGER NOT NULL, rows INTEGER NOT NULL, cols INTEGER NOT "
    "NULL, data BLOB, FOREIGN KEY(image_id) REFERENCES images(image_id) ON "
    "DELETE CASCADE);";
constexpr char kMatches[] =
    "CREATE TABLE IF NOT EXISTS matches (pair_id INTEGER PRIMARY KEY NOT "
    "NULL, rows INTEGER NOT NULL, cols INTEGER NOT NULL, data BLOB);";
constexpr char kTwoViewGeometries[] =
    "CREATE TABLE IF NOT EXISTS two_view_geometries (pair_id INTEGER PRIMARY "
    "KEY NOT NULL, rows INTEGER NOT NULL, cols INTEGER NOT NULL, data BLOB, "
    "config INTEGER NOT NULL, F BLOB, E BLOB, H BLOB, qvec BLOB, tvec BLOB);";

}  // namespace

std::vector<std::string> ColmapSchemaStatements(ColmapRelease release) {
  using R = ColmapRelease;
  if (release <= R::k3_9) return ColmapSchemaStatements();
  std::vector<std::string> out;
  if (release >= R::k3_12) {
    out.insert(out.end(), {kRigs, kRigIndex, kRigSensors, kRigSensorIndex});
  }
  out.push_back(kCameras);
  if (release >= R::k3_12) out.insert(out.end(), {kFrames, kFrameData, kFrameDataIndex});
  out.insert(out.end(), {kImages, kImageNameIndex});
  if (release >= R::k4_0) {
    out.insert(out.end(), {kPosePriors40, kPosePriorIndex40});
  } else {
    out.push_back(release >= R::k3_11 ? kPosePriors311 : kPosePriors310);
  }
  out.push_back(kKeypoints);
  out.push_back(release >= R::k4_0 ? kDescriptors40 : kDescriptors);
  out.insert(out.end(), {kMatches, kTwoViewGeometries});
  return out;
}

int ColmapSchemaUserVersion(ColmapRelease release) {
  using R = ColmapRelease;
  if (release == R::k3_8) return 3800;
  if (release <= R::k3_12) return 3900;
  const std::string name = ColmapReleaseName(release);
  const size_t dot = name.find('.');
  return std::stoi(name.substr(0, dot)) * 1000000 +
         std::stoi(name.substr(dot + 1)) * 10000;
}

}  // namespace hisfm
