// COLMAP's rigs and frames (3.12 and later), as databases and models store
// them. A rig is a set of sensors (cameras, IMUs) with fixed poses relative
// to its reference sensor; a frame is one capture of a rig: its pose and the
// data (images) each sensor took. Images without a configured rig get a
// trivial rig of one camera and a frame of one image.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "hisfm/util/rigid3d.h"

namespace hisfm {

/// COLMAP's SensorType values.
enum class SensorType : int { kInvalid = -1, kCamera = 0, kImu = 1 };

/// "CAMERA", "IMU", "INVALID": the names COLMAP's text files use.
std::string SensorTypeName(SensorType type);
/// The type of a name of SensorTypeName; throws hisfm::Error if unknown.
SensorType SensorTypeFromName(const std::string& name);

/// A sensor: its type and its id among the sensors of that type (a camera's
/// camera_id).
struct SensorId {
  SensorType type = SensorType::kInvalid;
  uint32_t id = 0;

  bool operator==(const SensorId& other) const {
    return type == other.type && id == other.id;
  }
};

/// A sensor of a rig other than its reference sensor.
struct RigSensor {
  SensorId sensor;
  /// The sensor's pose in the rig frame, if known.
  std::optional<Rigid3d> sensor_from_rig;
};

/// A rig: a reference sensor and the other sensors.
struct Rig {
  uint32_t rig_id = 0;
  /// Absent for a rig without sensors (models allow it, databases do not).
  std::optional<SensorId> ref_sensor;
  std::vector<RigSensor> sensors;
};

/// One piece of data of a frame: which sensor took it, and its id (an
/// image_id for a camera).
struct FrameData {
  SensorId sensor;
  uint64_t data_id = 0;
};

/// A frame: one capture of a rig.
struct Frame {
  uint32_t frame_id = 0;
  uint32_t rig_id = 0;
  /// The rig's pose (models store it; databases do not).
  std::optional<Rigid3d> rig_from_world;
  std::vector<FrameData> data;
};

}  // namespace hisfm
