#include "hisfm/io/rigs.h"

#include "hisfm/util/error.h"

namespace hisfm {

std::string SensorTypeName(SensorType type) {
  switch (type) {
    case SensorType::kCamera:
      return "CAMERA";
    case SensorType::kImu:
      return "IMU";
    case SensorType::kInvalid:
      break;
  }
  return "INVALID";
}

SensorType SensorTypeFromName(const std::string& name) {
  if (name == "CAMERA") return SensorType::kCamera;
  if (name == "IMU") return SensorType::kImu;
  if (name == "INVALID") return SensorType::kInvalid;
  throw Error(StrCat("unknown sensor type '", name,
                     "' (CAMERA, IMU or INVALID)"));
}

}  // namespace hisfm
