#include "hisfm/io/model.h"

#include <algorithm>
#include <array>
#include <charconv>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <set>
#include <unordered_set>

#include "hisfm/io/model_validation.h"
#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"

namespace fs = std::filesystem;

namespace hisfm {
namespace {

struct CameraModelInfo {
  int model_id;
  const char* name;
  int num_params;
  // The focal lengths are the first parameters: f, or fx and fy.
  int num_focal_lengths;
};

// COLMAP's camera models (3.8: src/base/camera_models.h; later
// src/colmap/sensor/models.h, CAMERA_MODEL_DEFINITIONS): ids 0-10 in every
// release, 11 from 3.11, 12-15 from 4.0, 16-17 from 4.1. Ids are never
// reused, so one table reads every release's files. EQUIRECTANGULAR has no
// focal length: its two parameters are metadata (the panorama's size).
constexpr std::array<CameraModelInfo, 18> kCameraModels = {{
    {0, "SIMPLE_PINHOLE", 3, 1},
    {1, "PINHOLE", 4, 2},
    {2, "SIMPLE_RADIAL", 4, 1},
    {3, "RADIAL", 5, 1},
    {4, "OPENCV", 8, 2},
    {5, "OPENCV_FISHEYE", 8, 2},
    {6, "FULL_OPENCV", 12, 2},
    {7, "FOV", 5, 2},
    {8, "SIMPLE_RADIAL_FISHEYE", 4, 1},
    {9, "RADIAL_FISHEYE", 5, 1},
    {10, "THIN_PRISM_FISHEYE", 12, 2},
    {11, "RAD_TAN_THIN_PRISM_FISHEYE", 16, 2},
    {12, "SIMPLE_DIVISION", 4, 1},
    {13, "DIVISION", 5, 2},
    {14, "SIMPLE_FISHEYE", 3, 1},
    {15, "FISHEYE", 4, 2},
    {16, "EUCM", 6, 2},
    {17, "EQUIRECTANGULAR", 2, 0},
}};

std::string JoinPath(const std::string& folder, const std::string& file) {
  return (fs::path(folder) / file).string();
}

// ---------------------------------------------------------------------------
// Record order.

// Ids of `map` in the order of `order` (skipping ids not in the map and
// repeated ids), followed by the remaining ids in increasing order.
template <typename Key, typename Value>
std::vector<Key> EffectiveOrder(const std::vector<Key>& order,
                                const std::map<Key, Value>& map) {
  std::vector<Key> out;
  out.reserve(map.size());
  std::unordered_set<Key> seen;
  seen.reserve(map.size());
  for (const Key key : order) {
    if (map.count(key) > 0 && seen.insert(key).second) out.push_back(key);
  }
  if (out.size() < map.size()) {
    for (const auto& [key, value] : map) {
      if (seen.count(key) == 0) out.push_back(key);
    }
  }
  return out;
}

// The order in which COLMAP iterates a reconstruction's hash map
// (std::unordered_map with the identity hash of integer ids, libstdc++)
// after inserting the ids in `insertion_order` into an empty map, as its
// readers do. Filling a std::unordered_set with the same key type in the same
// order reproduces it exactly.
template <typename Key>
std::vector<Key> ColmapHashMapOrder(const std::vector<Key>& insertion_order) {
  std::unordered_set<Key> set;
  for (const Key key : insertion_order) set.insert(key);
  return std::vector<Key>(set.begin(), set.end());
}

// ---------------------------------------------------------------------------
// Binary files.

class BinaryReader {
 public:
  BinaryReader(std::string path, std::string data)
      : path_(std::move(path)), data_(std::move(data)) {}

  template <typename T>
  T Read() {
    static_assert(std::is_trivially_copyable<T>::value, "POD only");
    Require(sizeof(T));
    T value;
    std::memcpy(&value, data_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return value;
  }

  // A NUL-terminated string.
  std::string ReadString() {
    const size_t end = data_.find('\0', pos_);
    if (end == std::string::npos) Fail("truncated (unterminated image name)");
    std::string out = data_.substr(pos_, end - pos_);
    pos_ = end + 1;
    return out;
  }

  // Reads a count of records of at least `min_record_bytes` bytes each and
  // checks that the file can hold them (guards against huge allocations).
  uint64_t ReadCount(size_t min_record_bytes) {
    const uint64_t count = Read<uint64_t>();
    if (count > Remaining() / min_record_bytes) {
      Fail(StrCat("truncated (", count, " records announced at byte ",
                  pos_ - sizeof(uint64_t), ")"));
    }
    return count;
  }

  void ExpectEnd() {
    if (pos_ != data_.size()) {
      Fail(StrCat(data_.size() - pos_, " unexpected trailing bytes"));
    }
  }

  [[noreturn]] void Fail(const std::string& what) const {
    throw Error(StrCat("malformed COLMAP model file ", path_, ": ", what));
  }

 private:
  size_t Remaining() const { return data_.size() - pos_; }
  void Require(size_t bytes) {
    if (Remaining() < bytes) {
      Fail(StrCat("truncated at byte ", pos_, " of ", data_.size()));
    }
  }

  std::string path_;
  std::string data_;
  size_t pos_ = 0;
};

class BinaryWriter {
 public:
  template <typename T>
  void Write(const T& value) {
    static_assert(std::is_trivially_copyable<T>::value, "POD only");
    const size_t old = data_.size();
    data_.resize(old + sizeof(T));
    std::memcpy(&data_[old], &value, sizeof(T));
  }
  void WriteString(const std::string& s) {
    data_.append(s);
    data_.push_back('\0');
  }
  void Reserve(size_t bytes) { data_.reserve(bytes); }
  const std::string& data() const { return data_; }

 private:
  std::string data_;
};

BinaryReader OpenBinary(const std::string& path) {
  CheckFileReadable(path, "COLMAP model file");
  return BinaryReader(path, ReadTextFile(path));
}

void ReadCamerasBinary(const std::string& path, Reconstruction* model) {
  BinaryReader in = OpenBinary(path);
  const uint64_t num_cameras = in.ReadCount(24);
  for (uint64_t i = 0; i < num_cameras; ++i) {
    Camera camera;
    camera.camera_id = in.Read<uint32_t>();
    camera.model_id = in.Read<int32_t>();
    camera.width = in.Read<uint64_t>();
    camera.height = in.Read<uint64_t>();
    const int num_params = CameraModelNumParams(camera.model_id);
    if (num_params < 0) {
      in.Fail(StrCat("camera ", camera.camera_id, " has unknown model id ",
                     camera.model_id));
    }
    camera.params.resize(num_params);
    for (double& param : camera.params) param = in.Read<double>();
    if (!model->cameras.emplace(camera.camera_id, camera).second) {
      in.Fail(StrCat("camera ", camera.camera_id, " appears twice"));
    }
    model->file_order.cameras.push_back(camera.camera_id);
  }
  in.ExpectEnd();
}

void ReadImagesBinary(const std::string& path, Reconstruction* model) {
  BinaryReader in = OpenBinary(path);
  const uint64_t num_images = in.ReadCount(4 + 7 * 8 + 4 + 1 + 8);
  for (uint64_t i = 0; i < num_images; ++i) {
    Image image;
    image.image_id = in.Read<uint32_t>();
    const double qw = in.Read<double>();
    const double qx = in.Read<double>();
    const double qy = in.Read<double>();
    const double qz = in.Read<double>();
    image.cam_from_world.rotation = Eigen::Quaterniond(qw, qx, qy, qz);
    for (int k = 0; k < 3; ++k) {
      image.cam_from_world.translation(k) = in.Read<double>();
    }
    image.camera_id = in.Read<uint32_t>();
    image.name = in.ReadString();
    const uint64_t num_points2D = in.ReadCount(24);
    image.points2D.resize(num_points2D);
    for (Point2D& point : image.points2D) {
      point.xy.x() = in.Read<double>();
      point.xy.y() = in.Read<double>();
      point.point3D_id = in.Read<uint64_t>();
    }
    if (model->cameras.count(image.camera_id) == 0) {
      in.Fail(StrCat("image ", image.image_id, " refers to missing camera ",
                     image.camera_id));
    }
    const ImageId image_id = image.image_id;
    if (!model->images.emplace(image_id, std::move(image)).second) {
      in.Fail(StrCat("image ", image_id, " appears twice"));
    }
    model->file_order.images.push_back(image_id);
  }
  in.ExpectEnd();
}

void ReadPoints3DBinary(const std::string& path, Reconstruction* model) {
  BinaryReader in = OpenBinary(path);
  const uint64_t num_points = in.ReadCount(8 + 24 + 3 + 8 + 8);
  for (uint64_t i = 0; i < num_points; ++i) {
    const Point3DId point3D_id = in.Read<uint64_t>();
    Point3D point;
    for (int k = 0; k < 3; ++k) point.xyz(k) = in.Read<double>();
    for (int k = 0; k < 3; ++k) point.color(k) = in.Read<uint8_t>();
    point.error = in.Read<double>();
    const uint64_t track_length = in.ReadCount(8);
    point.track.resize(track_length);
    for (TrackElement& element : point.track) {
      element.image_id = in.Read<uint32_t>();
      element.point2D_idx = in.Read<uint32_t>();
    }
    if (!model->points3D.emplace(point3D_id, std::move(point)).second) {
      in.Fail(StrCat("point ", point3D_id, " appears twice"));
    }
    model->file_order.points3D.push_back(point3D_id);
  }
  in.ExpectEnd();
}

// ---------------------------------------------------------------------------
// Text files.

// COLMAP writes floating-point numbers through a stream with precision 17
// and the default float field, i.e. printf's "%.17g".
void AppendDouble(double value, std::string* out) {
  char buffer[64];
  const int n = std::snprintf(buffer, sizeof(buffer), "%.17g", value);
  out->append(buffer, n);
}

template <typename Int>
void AppendInt(Int value, std::string* out) {
  char buffer[32];
  const auto result = std::to_chars(buffer, buffer + sizeof(buffer), value);
  out->append(buffer, result.ptr);
}

// COLMAP's NormalizeQuaternion (src/base/pose.cc) on (w, x, y, z).
Eigen::Vector4d NormalizeQvec(const Eigen::Vector4d& qvec) {
  const double norm = qvec.norm();
  if (norm == 0) return Eigen::Vector4d(1.0, qvec(1), qvec(2), qvec(3));
  return qvec / norm;
}

// Number of points2D that observe a 3D point, summed over all images: what
// COLMAP's text headers call the number of observations.
size_t NumImageObservations(const Reconstruction& model) {
  size_t num = 0;
  for (const auto& [image_id, image] : model.images) {
    for (const Point2D& point : image.points2D) {
      if (point.point3D_id != kInvalidPoint3DId) ++num;
    }
  }
  return num;
}

// Splits a line at single spaces like COLMAP's getline(stream, item, ' ').
std::vector<std::string_view> SplitSpaces(std::string_view line) {
  std::vector<std::string_view> items;
  size_t start = 0;
  while (start <= line.size()) {
    size_t end = line.find(' ', start);
    if (end == std::string_view::npos) end = line.size();
    items.push_back(line.substr(start, end - start));
    start = end + 1;
  }
  return items;
}

std::string_view Trim(std::string_view s) {
  const char* kSpace = " \t\r\n\f\v";
  const size_t begin = s.find_first_not_of(kSpace);
  if (begin == std::string_view::npos) return {};
  const size_t end = s.find_last_not_of(kSpace);
  return s.substr(begin, end - begin + 1);
}

// Lines of a text file with their 1-based numbers.
class TextReader {
 public:
  explicit TextReader(const std::string& path) : path_(path) {
    CheckFileReadable(path, "COLMAP model file");
    data_ = ReadTextFile(path);
  }

  // Next line (trimmed); false at the end of the file.
  bool NextLine(std::string_view* line) {
    if (pos_ >= data_.size()) return false;
    size_t end = data_.find('\n', pos_);
    if (end == std::string::npos) end = data_.size();
    *line = Trim(std::string_view(data_).substr(pos_, end - pos_));
    pos_ = end + 1;
    ++line_number_;
    return true;
  }

  // Next line that is neither empty nor a comment.
  bool NextDataLine(std::string_view* line) {
    while (NextLine(line)) {
      if (!line->empty() && (*line)[0] != '#') return true;
    }
    return false;
  }

  [[noreturn]] void Fail(const std::string& what) const {
    throw Error(StrCat("malformed COLMAP model file ", path_, " line ",
                       line_number_, ": ", what));
  }

  double ParseDouble(std::string_view item) const {
    double value = 0;
    const auto result =
        std::from_chars(item.data(), item.data() + item.size(), value);
    if (item.empty() || result.ec != std::errc() ||
        result.ptr != item.data() + item.size()) {
      Fail(StrCat("'", item, "' is not a number"));
    }
    return value;
  }

  template <typename Int>
  Int ParseInt(std::string_view item) const {
    Int value = 0;
    const auto result =
        std::from_chars(item.data(), item.data() + item.size(), value);
    if (item.empty() || result.ec != std::errc() ||
        result.ptr != item.data() + item.size()) {
      Fail(StrCat("'", item, "' is not a valid integer"));
    }
    return value;
  }

 private:
  std::string path_;
  std::string data_;
  size_t pos_ = 0;
  size_t line_number_ = 0;
};

void ReadCamerasText(const std::string& path, Reconstruction* model) {
  TextReader in(path);
  std::string_view line;
  while (in.NextDataLine(&line)) {
    const std::vector<std::string_view> items = SplitSpaces(line);
    if (items.size() < 4) in.Fail("expected CAMERA_ID MODEL WIDTH HEIGHT");
    Camera camera;
    camera.camera_id = in.ParseInt<uint32_t>(items[0]);
    camera.model_id = CameraModelNameToId(std::string(items[1]));
    if (camera.model_id < 0) {
      in.Fail(StrCat("unknown camera model '", items[1], "'"));
    }
    camera.width = in.ParseInt<uint64_t>(items[2]);
    camera.height = in.ParseInt<uint64_t>(items[3]);
    for (size_t i = 4; i < items.size(); ++i) {
      camera.params.push_back(in.ParseDouble(items[i]));
    }
    if (static_cast<int>(camera.params.size()) !=
        CameraModelNumParams(camera.model_id)) {
      in.Fail(StrCat(items[1], " needs ",
                     CameraModelNumParams(camera.model_id),
                     " parameters, found ", camera.params.size()));
    }
    if (!model->cameras.emplace(camera.camera_id, camera).second) {
      in.Fail(StrCat("camera ", camera.camera_id, " appears twice"));
    }
    model->file_order.cameras.push_back(camera.camera_id);
  }
}

void ReadImagesText(const std::string& path, Reconstruction* model) {
  TextReader in(path);
  std::string_view line;
  while (in.NextDataLine(&line)) {
    const std::vector<std::string_view> items = SplitSpaces(line);
    if (items.size() < 10) {
      in.Fail("expected IMAGE_ID QW QX QY QZ TX TY TZ CAMERA_ID NAME");
    }
    Image image;
    image.image_id = in.ParseInt<uint32_t>(items[0]);
    const double qw = in.ParseDouble(items[1]);
    const double qx = in.ParseDouble(items[2]);
    const double qy = in.ParseDouble(items[3]);
    const double qz = in.ParseDouble(items[4]);
    image.cam_from_world.rotation = Eigen::Quaterniond(qw, qx, qy, qz);
    for (int k = 0; k < 3; ++k) {
      image.cam_from_world.translation(k) = in.ParseDouble(items[5 + k]);
    }
    image.camera_id = in.ParseInt<uint32_t>(items[8]);
    // The name is the rest of the line (COLMAP writes it last).
    const size_t name_start = items[9].data() - line.data();
    image.name = std::string(line.substr(name_start));
    if (model->cameras.count(image.camera_id) == 0) {
      in.Fail(StrCat("image ", image.image_id, " refers to missing camera ",
                     image.camera_id));
    }
    // The second line lists the points2D; it may be empty.
    std::string_view points_line;
    if (!in.NextLine(&points_line)) {
      in.Fail(StrCat("image ", image.image_id, " lacks its POINTS2D line"));
    }
    if (!points_line.empty()) {
      const std::vector<std::string_view> values = SplitSpaces(points_line);
      if (values.size() % 3 != 0) {
        in.Fail("POINTS2D must be triples X Y POINT3D_ID");
      }
      image.points2D.resize(values.size() / 3);
      for (size_t i = 0; i < image.points2D.size(); ++i) {
        Point2D& point = image.points2D[i];
        point.xy.x() = in.ParseDouble(values[3 * i]);
        point.xy.y() = in.ParseDouble(values[3 * i + 1]);
        const std::string_view id = values[3 * i + 2];
        point.point3D_id =
            id == "-1" ? kInvalidPoint3DId : in.ParseInt<uint64_t>(id);
      }
    }
    const ImageId image_id = image.image_id;
    if (!model->images.emplace(image_id, std::move(image)).second) {
      in.Fail(StrCat("image ", image_id, " appears twice"));
    }
    model->file_order.images.push_back(image_id);
  }
}

void ReadPoints3DText(const std::string& path, Reconstruction* model) {
  TextReader in(path);
  std::string_view line;
  while (in.NextDataLine(&line)) {
    const std::vector<std::string_view> items = SplitSpaces(line);
    if (items.size() < 8 || (items.size() - 8) % 2 != 0) {
      in.Fail("expected POINT3D_ID X Y Z R G B ERROR and (IMAGE_ID, "
              "POINT2D_IDX) pairs");
    }
    const Point3DId point3D_id = in.ParseInt<uint64_t>(items[0]);
    Point3D point;
    for (int k = 0; k < 3; ++k) point.xyz(k) = in.ParseDouble(items[1 + k]);
    for (int k = 0; k < 3; ++k) {
      const unsigned value = in.ParseInt<unsigned>(items[4 + k]);
      if (value > 255) in.Fail(StrCat("colour value ", value, " exceeds 255"));
      point.color(k) = static_cast<uint8_t>(value);
    }
    point.error = in.ParseDouble(items[7]);
    point.track.resize((items.size() - 8) / 2);
    for (size_t i = 0; i < point.track.size(); ++i) {
      point.track[i].image_id = in.ParseInt<uint32_t>(items[8 + 2 * i]);
      point.track[i].point2D_idx = in.ParseInt<uint32_t>(items[9 + 2 * i]);
    }
    if (!model->points3D.emplace(point3D_id, std::move(point)).second) {
      in.Fail(StrCat("point ", point3D_id, " appears twice"));
    }
    model->file_order.points3D.push_back(point3D_id);
  }
}

// ---------------------------------------------------------------------------
// Rigs and frames (COLMAP 3.12 and later).

Rigid3d ReadPoseBinary(BinaryReader* in) {
  double v[7];
  for (double& x : v) x = in->Read<double>();
  return Rigid3d(Eigen::Quaterniond(v[0], v[1], v[2], v[3]),
                 Eigen::Vector3d(v[4], v[5], v[6]));
}

void WritePoseBinary(const Rigid3d& pose, BinaryWriter* out) {
  const Eigen::Quaterniond& q = pose.rotation;
  for (const double x : {q.w(), q.x(), q.y(), q.z(), pose.translation.x(),
                         pose.translation.y(), pose.translation.z()}) {
    out->Write<double>(x);
  }
}

SensorId ReadSensorBinary(BinaryReader* in) {
  SensorId sensor;
  sensor.type = static_cast<SensorType>(in->Read<int32_t>());
  sensor.id = in->Read<uint32_t>();
  return sensor;
}

std::vector<Rig> ReadRigsBinary(const std::string& path) {
  BinaryReader in = OpenBinary(path);
  const uint64_t num_rigs = in.ReadCount(8);
  std::vector<Rig> rigs(num_rigs);
  for (Rig& rig : rigs) {
    rig.rig_id = in.Read<uint32_t>();
    const uint32_t num_sensors = in.Read<uint32_t>();
    if (num_sensors == 0) continue;
    rig.ref_sensor = ReadSensorBinary(&in);
    for (uint32_t k = 1; k < num_sensors; ++k) {
      RigSensor sensor;
      sensor.sensor = ReadSensorBinary(&in);
      if (in.Read<uint8_t>() != 0) sensor.sensor_from_rig = ReadPoseBinary(&in);
      rig.sensors.push_back(sensor);
    }
  }
  in.ExpectEnd();
  return rigs;
}

std::vector<Frame> ReadFramesBinary(const std::string& path) {
  BinaryReader in = OpenBinary(path);
  const uint64_t num_frames = in.ReadCount(8 + 56 + 4);
  std::vector<Frame> frames(num_frames);
  for (Frame& frame : frames) {
    frame.frame_id = in.Read<uint32_t>();
    frame.rig_id = in.Read<uint32_t>();
    frame.rig_from_world = ReadPoseBinary(&in);
    const uint32_t num_data = in.Read<uint32_t>();
    for (uint32_t k = 0; k < num_data; ++k) {
      FrameData data;
      data.sensor = ReadSensorBinary(&in);
      data.data_id = in.Read<uint64_t>();
      frame.data.push_back(data);
    }
  }
  in.ExpectEnd();
  return frames;
}

std::string RigsBinary(const std::vector<Rig>& rigs) {
  BinaryWriter out;
  out.Write<uint64_t>(rigs.size());
  for (const Rig& rig : rigs) {
    out.Write<uint32_t>(rig.rig_id);
    if (!rig.ref_sensor) {
      out.Write<uint32_t>(0);
      continue;
    }
    out.Write<uint32_t>(static_cast<uint32_t>(rig.sensors.size() + 1));
    out.Write<int32_t>(static_cast<int32_t>(rig.ref_sensor->type));
    out.Write<uint32_t>(rig.ref_sensor->id);
    for (const RigSensor& sensor : rig.sensors) {
      out.Write<int32_t>(static_cast<int32_t>(sensor.sensor.type));
      out.Write<uint32_t>(sensor.sensor.id);
      out.Write<uint8_t>(sensor.sensor_from_rig ? 1 : 0);
      if (sensor.sensor_from_rig) WritePoseBinary(*sensor.sensor_from_rig, &out);
    }
  }
  return out.data();
}

std::string FramesBinary(const std::vector<Frame>& frames) {
  BinaryWriter out;
  size_t num_posed = 0;
  for (const Frame& frame : frames) num_posed += frame.rig_from_world ? 1 : 0;
  out.Write<uint64_t>(num_posed);
  for (const Frame& frame : frames) {
    // COLMAP writes the frames that have a pose.
    if (!frame.rig_from_world) continue;
    out.Write<uint32_t>(frame.frame_id);
    out.Write<uint32_t>(frame.rig_id);
    WritePoseBinary(*frame.rig_from_world, &out);
    out.Write<uint32_t>(static_cast<uint32_t>(frame.data.size()));
    for (const FrameData& data : frame.data) {
      out.Write<int32_t>(static_cast<int32_t>(data.sensor.type));
      out.Write<uint32_t>(data.sensor.id);
      out.Write<uint64_t>(data.data_id);
    }
  }
  return out.data();
}

// The items of a data line of rigs.txt or frames.txt, read in order.
class TextItems {
 public:
  TextItems(const TextReader& in, std::string_view line)
      : in_(in), items_(SplitSpaces(line)) {}
  std::string_view Next() {
    if (next_ >= items_.size()) in_.Fail("line ends too early");
    return items_[next_++];
  }
  template <typename Int>
  Int NextInt() {
    return in_.ParseInt<Int>(Next());
  }
  double NextDouble() { return in_.ParseDouble(Next()); }
  SensorId Sensor() {
    SensorId sensor;
    const std::string_view name = Next();
    try {
      sensor.type = SensorTypeFromName(std::string(name));
    } catch (const Error& e) {
      in_.Fail(e.what());
    }
    sensor.id = NextInt<uint32_t>();
    return sensor;
  }
  Rigid3d Pose() {
    double v[7];
    for (double& x : v) x = NextDouble();
    return Rigid3d(Eigen::Quaterniond(v[0], v[1], v[2], v[3]),
                   Eigen::Vector3d(v[4], v[5], v[6]));
  }
  void ExpectEnd() const {
    if (next_ != items_.size()) in_.Fail("unexpected values at the end");
  }

 private:
  const TextReader& in_;
  std::vector<std::string_view> items_;
  size_t next_ = 0;
};

std::vector<Rig> ReadRigsText(const std::string& path) {
  TextReader in(path);
  std::vector<Rig> rigs;
  std::string_view line;
  while (in.NextDataLine(&line)) {
    TextItems items(in, line);
    Rig rig;
    rig.rig_id = items.NextInt<uint32_t>();
    const uint64_t num_sensors = items.NextInt<uint64_t>();
    if (num_sensors > 0) rig.ref_sensor = items.Sensor();
    for (uint64_t k = 1; k < num_sensors; ++k) {
      RigSensor sensor;
      sensor.sensor = items.Sensor();
      if (items.NextInt<int>() == 1) sensor.sensor_from_rig = items.Pose();
      rig.sensors.push_back(sensor);
    }
    items.ExpectEnd();
    rigs.push_back(std::move(rig));
  }
  return rigs;
}

std::vector<Frame> ReadFramesText(const std::string& path) {
  TextReader in(path);
  std::vector<Frame> frames;
  std::string_view line;
  while (in.NextDataLine(&line)) {
    TextItems items(in, line);
    Frame frame;
    frame.frame_id = items.NextInt<uint32_t>();
    frame.rig_id = items.NextInt<uint32_t>();
    frame.rig_from_world = items.Pose();
    const uint32_t num_data = items.NextInt<uint32_t>();
    for (uint32_t k = 0; k < num_data; ++k) {
      FrameData data;
      data.sensor = items.Sensor();
      data.data_id = items.NextInt<uint64_t>();
      frame.data.push_back(data);
    }
    items.ExpectEnd();
    frames.push_back(std::move(frame));
  }
  return frames;
}

void AppendPoseText(const Rigid3d& pose, std::string* out) {
  const Eigen::Quaterniond& q = pose.rotation;
  for (const double x : {q.w(), q.x(), q.y(), q.z(), pose.translation.x(),
                         pose.translation.y(), pose.translation.z()}) {
    AppendDouble(x, out);
    *out += ' ';
  }
}

std::string RigsText(std::vector<Rig> rigs) {
  std::sort(rigs.begin(), rigs.end(),
            [](const Rig& a, const Rig& b) { return a.rig_id < b.rig_id; });
  std::string out =
      "# Rig calib list with one line of data per calib:\n"
      "#   RIG_ID, NUM_SENSORS, REF_SENSOR_TYPE, REF_SENSOR_ID, SENSORS[] as "
      "(SENSOR_TYPE, SENSOR_ID, HAS_POSE, [QW, QX, QY, QZ, TX, TY, TZ])\n"
      "# Number of rigs: ";
  AppendInt(rigs.size(), &out);
  out += '\n';
  for (const Rig& rig : rigs) {
    std::string line;
    AppendInt(rig.rig_id, &line);
    line += ' ';
    AppendInt(rig.ref_sensor ? rig.sensors.size() + 1 : 0, &line);
    line += ' ';
    if (rig.ref_sensor) {
      line += SensorTypeName(rig.ref_sensor->type) + ' ';
      AppendInt(rig.ref_sensor->id, &line);
      line += ' ';
      for (const RigSensor& sensor : rig.sensors) {
        line += SensorTypeName(sensor.sensor.type) + ' ';
        AppendInt(sensor.sensor.id, &line);
        line += sensor.sensor_from_rig ? " 1 " : " 0 ";
        if (sensor.sensor_from_rig) AppendPoseText(*sensor.sensor_from_rig, &line);
      }
    }
    // COLMAP drops the last space.
    line.pop_back();
    out += line + '\n';
  }
  return out;
}

std::string FramesText(std::vector<Frame> frames) {
  frames.erase(std::remove_if(frames.begin(), frames.end(),
                              [](const Frame& f) { return !f.rig_from_world; }),
               frames.end());
  std::sort(frames.begin(), frames.end(), [](const Frame& a, const Frame& b) {
    return a.frame_id < b.frame_id;
  });
  std::string out =
      "# Frame list with one line of data per frame:\n"
      "#   FRAME_ID, RIG_ID, RIG_FROM_WORLD[QW, QX, QY, QZ, TX, TY, TZ], "
      "NUM_DATA_IDS, DATA_IDS[] as (SENSOR_TYPE, SENSOR_ID, DATA_ID)\n"
      "# Number of frames: ";
  AppendInt(frames.size(), &out);
  out += '\n';
  for (const Frame& frame : frames) {
    AppendInt(frame.frame_id, &out);
    out += ' ';
    AppendInt(frame.rig_id, &out);
    out += ' ';
    AppendPoseText(*frame.rig_from_world, &out);
    AppendInt(frame.data.size(), &out);
    for (const FrameData& data : frame.data) {
      out += ' ' + SensorTypeName(data.sensor.type) + ' ';
      AppendInt(data.sensor.id, &out);
      out += ' ';
      AppendInt(data.data_id, &out);
    }
    out += '\n';
  }
  return out;
}

bool ExistsFile(const std::string& path) {
  std::error_code ec;
  return fs::is_regular_file(path, ec);
}

Reconstruction ReadModelBinaryFiles(const std::string& path) {
  CheckDirectoryExists(path, "COLMAP model");
  Reconstruction model;
  ReadCamerasBinary(JoinPath(path, "cameras.bin"), &model);
  ReadImagesBinary(JoinPath(path, "images.bin"), &model);
  ReadPoints3DBinary(JoinPath(path, "points3D.bin"), &model);
  if (ExistsFile(JoinPath(path, "rigs.bin"))) {
    model.rigs = ReadRigsBinary(JoinPath(path, "rigs.bin"));
  }
  if (ExistsFile(JoinPath(path, "frames.bin"))) {
    model.frames = ReadFramesBinary(JoinPath(path, "frames.bin"));
  }
  return model;
}

Reconstruction ReadModelTextFiles(const std::string& path) {
  CheckDirectoryExists(path, "COLMAP model");
  Reconstruction model;
  ReadCamerasText(JoinPath(path, "cameras.txt"), &model);
  ReadImagesText(JoinPath(path, "images.txt"), &model);
  ReadPoints3DText(JoinPath(path, "points3D.txt"), &model);
  if (ExistsFile(JoinPath(path, "rigs.txt"))) {
    model.rigs = ReadRigsText(JoinPath(path, "rigs.txt"));
  }
  if (ExistsFile(JoinPath(path, "frames.txt"))) {
    model.frames = ReadFramesText(JoinPath(path, "frames.txt"));
  }
  return model;
}

void CheckOutputFolder(const std::string& path) {
  CheckDirectoryExists(path, "model output folder");
}

}  // namespace

// ---------------------------------------------------------------------------
// Reconstruction.

const Image* Reconstruction::FindImageWithName(const std::string& name) const {
  for (const auto& [image_id, image] : images) {
    if (image.name == name) return &image;
  }
  return nullptr;
}

double Reconstruction::MeanTrackLength() const {
  if (points3D.empty()) return 0.0;
  return static_cast<double>(NumObservations()) /
         static_cast<double>(points3D.size());
}

double Reconstruction::MeanReprojectionError() const {
  // Like COLMAP, points without an error (stored as -1) are left out.
  double sum = 0.0;
  size_t num = 0;
  for (const auto& [point3D_id, point] : points3D) {
    if (point.error != -1.0) {
      sum += point.error;
      ++num;
    }
  }
  return num == 0 ? 0.0 : sum / static_cast<double>(num);
}

size_t Reconstruction::NumObservations() const {
  size_t num = 0;
  for (const auto& [point3D_id, point] : points3D) num += point.track.size();
  return num;
}

int CameraModelNumParams(int model_id) {
  for (const CameraModelInfo& info : kCameraModels) {
    if (info.model_id == model_id) return info.num_params;
  }
  return -1;
}

int CameraModelNumFocalLengths(int model_id) {
  for (const CameraModelInfo& info : kCameraModels) {
    if (info.model_id == model_id) return info.num_focal_lengths;
  }
  return 0;
}

std::string CameraModelIdToName(int model_id) {
  for (const CameraModelInfo& info : kCameraModels) {
    if (info.model_id == model_id) return info.name;
  }
  return "";
}

int CameraModelNameToId(const std::string& name) {
  for (const CameraModelInfo& info : kCameraModels) {
    if (name == info.name) return info.model_id;
  }
  return -1;
}

// ---------------------------------------------------------------------------
// Reading.

Reconstruction ReadModelUnvalidated(const std::string& path) {
  CheckDirectoryExists(path, "COLMAP model");
  if (ExistsFile(JoinPath(path, "cameras.bin"))) {
    return ReadModelBinaryFiles(path);
  }
  if (ExistsFile(JoinPath(path, "cameras.txt"))) {
    return ReadModelTextFiles(path);
  }
  throw Error(StrCat("no COLMAP model (cameras.bin or cameras.txt) in ", path));
}

Reconstruction ReadModel(const std::string& path) {
  Reconstruction model = ReadModelUnvalidated(path);
  RequireValidModel(model, path);
  return model;
}

bool HasModel(const std::string& path) {
  return ExistsFile(JoinPath(path, "cameras.bin")) ||
         ExistsFile(JoinPath(path, "cameras.txt"));
}

std::vector<std::string> NumberedModelFolders(const std::string& folder) {
  std::vector<std::pair<long, std::string>> found;
  std::error_code ec;
  for (const auto& entry : std::filesystem::directory_iterator(folder, ec)) {
    const std::string name = entry.path().filename().string();
    const bool number =
        !name.empty() && name.size() < 10 &&
        std::all_of(name.begin(), name.end(),
                    [](char c) { return c >= '0' && c <= '9'; });
    if (number && entry.is_directory(ec) && HasModel(entry.path().string())) {
      found.emplace_back(std::stol(name), entry.path().string());
    }
  }
  std::sort(found.begin(), found.end());
  std::vector<std::string> out;
  for (const auto& [number, path] : found) out.push_back(path);
  return out;
}

std::vector<std::string> ResultModelFolders(const std::string& model_path) {
  CheckDirectoryExists(model_path, "model");
  fs::path path = fs::absolute(model_path).lexically_normal();
  if (path.filename().empty()) path = path.parent_path();  // trailing '/'
  if (HasModel(path.string())) {
    // One of several numbered models: all of them.
    const std::vector<std::string> siblings =
        NumberedModelFolders(path.parent_path().string());
    if (siblings.size() > 1 &&
        std::find(siblings.begin(), siblings.end(), path.string()) !=
            siblings.end()) {
      return siblings;
    }
    return {path.string()};
  }
  const std::vector<std::string> inside = NumberedModelFolders(path.string());
  ThrowUnless(!inside.empty(),
              StrCat("no COLMAP model (cameras.bin or cameras.txt, or "
                     "numbered model folders) in ",
                     model_path));
  return inside;
}

std::vector<Reconstruction> ReadNumberedModels(const std::string& folder) {
  std::vector<Reconstruction> models;
  for (int i = 0;; ++i) {
    const std::string path = JoinPath(folder, std::to_string(i));
    if (!HasModel(path)) break;
    models.push_back(ReadModel(path));
  }
  return models;
}

Reconstruction ReadModelBinary(const std::string& path) {
  Reconstruction model = ReadModelBinaryFiles(path);
  RequireValidModel(model, path);
  return model;
}

Reconstruction ReadModelText(const std::string& path) {
  Reconstruction model = ReadModelTextFiles(path);
  RequireValidModel(model, path);
  return model;
}

// ---------------------------------------------------------------------------
// Writing.

void WriteModelBinary(const Reconstruction& model, const std::string& path) {
  CheckOutputFolder(path);
  {
    BinaryWriter out;
    out.Write<uint64_t>(model.cameras.size());
    for (const CameraId camera_id :
         EffectiveOrder(model.file_order.cameras, model.cameras)) {
      const Camera& camera = model.cameras.at(camera_id);
      ThrowUnless(static_cast<int>(camera.params.size()) ==
                      CameraModelNumParams(camera.model_id),
                  StrCat("cannot write camera ", camera_id, ": model id ",
                         camera.model_id, " with ", camera.params.size(),
                         " parameters"));
      out.Write<uint32_t>(camera_id);
      out.Write<int32_t>(camera.model_id);
      out.Write<uint64_t>(camera.width);
      out.Write<uint64_t>(camera.height);
      for (const double param : camera.params) out.Write<double>(param);
    }
    WriteFileAtomically(JoinPath(path, "cameras.bin"), out.data());
  }
  {
    BinaryWriter out;
    out.Write<uint64_t>(model.images.size());
    for (const ImageId image_id :
         EffectiveOrder(model.file_order.images, model.images)) {
      const Image& image = model.images.at(image_id);
      const Eigen::Quaterniond& q = image.cam_from_world.rotation;
      out.Write<uint32_t>(image_id);
      out.Write<double>(q.w());
      out.Write<double>(q.x());
      out.Write<double>(q.y());
      out.Write<double>(q.z());
      for (int k = 0; k < 3; ++k) {
        out.Write<double>(image.cam_from_world.translation(k));
      }
      out.Write<uint32_t>(image.camera_id);
      out.WriteString(image.name);
      out.Write<uint64_t>(image.points2D.size());
      for (const Point2D& point : image.points2D) {
        out.Write<double>(point.xy.x());
        out.Write<double>(point.xy.y());
        out.Write<uint64_t>(point.point3D_id);
      }
    }
    WriteFileAtomically(JoinPath(path, "images.bin"), out.data());
  }
  {
    BinaryWriter out;
    out.Reserve(8 + model.points3D.size() * 64 + NumImageObservations(model) * 8);
    out.Write<uint64_t>(model.points3D.size());
    for (const Point3DId point3D_id :
         EffectiveOrder(model.file_order.points3D, model.points3D)) {
      const Point3D& point = model.points3D.at(point3D_id);
      out.Write<uint64_t>(point3D_id);
      for (int k = 0; k < 3; ++k) out.Write<double>(point.xyz(k));
      for (int k = 0; k < 3; ++k) out.Write<uint8_t>(point.color(k));
      out.Write<double>(point.error);
      out.Write<uint64_t>(point.track.size());
      for (const TrackElement& element : point.track) {
        out.Write<uint32_t>(element.image_id);
        out.Write<uint32_t>(element.point2D_idx);
      }
    }
    WriteFileAtomically(JoinPath(path, "points3D.bin"), out.data());
  }
  if (model.rigs) WriteFileAtomically(JoinPath(path, "rigs.bin"), RigsBinary(*model.rigs));
  if (model.frames) {
    WriteFileAtomically(JoinPath(path, "frames.bin"),
                        FramesBinary(*model.frames));
  }
}

void WriteModelText(const Reconstruction& model, const std::string& path) {
  CheckOutputFolder(path);
  const size_t num_observations = NumImageObservations(model);
  {
    std::string out =
        "# Camera list with one line of data per camera:\n"
        "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
        "# Number of cameras: ";
    AppendInt(model.cameras.size(), &out);
    out += '\n';
    for (const CameraId camera_id : ColmapHashMapOrder(
             EffectiveOrder(model.file_order.cameras, model.cameras))) {
      const Camera& camera = model.cameras.at(camera_id);
      const std::string name = CameraModelIdToName(camera.model_id);
      ThrowUnless(!name.empty(), StrCat("cannot write camera ", camera_id,
                                        ": unknown model id ",
                                        camera.model_id));
      AppendInt(camera_id, &out);
      out += ' ';
      out += name;
      out += ' ';
      AppendInt(camera.width, &out);
      out += ' ';
      AppendInt(camera.height, &out);
      for (const double param : camera.params) {
        out += ' ';
        AppendDouble(param, &out);
      }
      out += '\n';
    }
    WriteFileAtomically(JoinPath(path, "cameras.txt"), out);
  }
  {
    std::string out =
        "# Image list with two lines of data per image:\n"
        "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n"
        "#   POINTS2D[] as (X, Y, POINT3D_ID)\n"
        "# Number of images: ";
    AppendInt(model.images.size(), &out);
    out += ", mean observations per image: ";
    AppendDouble(model.images.empty()
                     ? 0.0
                     : num_observations /
                           static_cast<double>(model.images.size()),
                 &out);
    out += '\n';
    for (const ImageId image_id : ColmapHashMapOrder(
             EffectiveOrder(model.file_order.images, model.images))) {
      const Image& image = model.images.at(image_id);
      const Eigen::Quaterniond& q = image.cam_from_world.rotation;
      // COLMAP normalizes when it reads a model and again when it writes.
      const Eigen::Vector4d qvec =
          NormalizeQvec(NormalizeQvec(Eigen::Vector4d(q.w(), q.x(), q.y(),
                                                      q.z())));
      AppendInt(image_id, &out);
      for (int k = 0; k < 4; ++k) {
        out += ' ';
        AppendDouble(qvec(k), &out);
      }
      for (int k = 0; k < 3; ++k) {
        out += ' ';
        AppendDouble(image.cam_from_world.translation(k), &out);
      }
      out += ' ';
      AppendInt(image.camera_id, &out);
      out += ' ';
      out += image.name;
      out += '\n';
      for (size_t i = 0; i < image.points2D.size(); ++i) {
        const Point2D& point = image.points2D[i];
        if (i > 0) out += ' ';
        AppendDouble(point.xy.x(), &out);
        out += ' ';
        AppendDouble(point.xy.y(), &out);
        out += ' ';
        if (point.point3D_id == kInvalidPoint3DId) {
          out += "-1";
        } else {
          AppendInt(point.point3D_id, &out);
        }
      }
      out += '\n';
    }
    WriteFileAtomically(JoinPath(path, "images.txt"), out);
  }
  {
    std::string out =
        "# 3D point list with one line of data per point:\n"
        "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, "
        "POINT2D_IDX)\n"
        "# Number of points: ";
    AppendInt(model.points3D.size(), &out);
    out += ", mean track length: ";
    AppendDouble(model.points3D.empty()
                     ? 0.0
                     : num_observations /
                           static_cast<double>(model.points3D.size()),
                 &out);
    out += '\n';
    for (const Point3DId point3D_id : ColmapHashMapOrder(
             EffectiveOrder(model.file_order.points3D, model.points3D))) {
      const Point3D& point = model.points3D.at(point3D_id);
      AppendInt(point3D_id, &out);
      for (int k = 0; k < 3; ++k) {
        out += ' ';
        AppendDouble(point.xyz(k), &out);
      }
      for (int k = 0; k < 3; ++k) {
        out += ' ';
        AppendInt(static_cast<int>(point.color(k)), &out);
      }
      out += ' ';
      AppendDouble(point.error, &out);
      // COLMAP leaves a space after the error, then the track.
      out += ' ';
      for (size_t i = 0; i < point.track.size(); ++i) {
        if (i > 0) out += ' ';
        AppendInt(point.track[i].image_id, &out);
        out += ' ';
        AppendInt(point.track[i].point2D_idx, &out);
      }
      out += '\n';
    }
    WriteFileAtomically(JoinPath(path, "points3D.txt"), out);
  }
  if (model.rigs) WriteFileAtomically(JoinPath(path, "rigs.txt"), RigsText(*model.rigs));
  if (model.frames) {
    WriteFileAtomically(JoinPath(path, "frames.txt"), FramesText(*model.frames));
  }
}

}  // namespace hisfm
