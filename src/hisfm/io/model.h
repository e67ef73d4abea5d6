// COLMAP sparse models (cameras, images, points3D) in memory, and their
// binary and text files.
//
// Binary format (COLMAP 3.8, src/base/reconstruction.cc), little-endian:
//   cameras.bin:  uint64 num_cameras; per camera: uint32 camera_id,
//                 int32 model_id, uint64 width, uint64 height,
//                 float64 params[num_params(model_id)].
//   images.bin:   uint64 num_reg_images; per image: uint32 image_id,
//                 float64 qw, qx, qy, qz, float64 tx, ty, tz (cam_from_world),
//                 uint32 camera_id, name as NUL-terminated chars,
//                 uint64 num_points2D; per point: float64 x, y,
//                 uint64 point3D_id (2^64-1 = none).
//   points3D.bin: uint64 num_points; per point: uint64 point3D_id,
//                 float64 x, y, z, uint8 r, g, b, float64 error,
//                 uint64 track_length; per element: uint32 image_id,
//                 uint32 point2D_idx.
// Text format: cameras.txt, images.txt (two lines per image), points3D.txt,
// with COLMAP's comment headers, written byte-identically to
// `colmap model_converter --output_type TXT`.
//
// COLMAP 3.12 and later also write rigs.bin and frames.bin (rigs.txt,
// frames.txt), read and written here as they are (src/colmap/scene/
// reconstruction_io_binary.cc, _text.cc):
//   rigs.bin:   uint64 num_rigs; per rig: uint32 rig_id, uint32 num_sensors;
//               if num_sensors > 0: int32 ref_sensor_type, uint32
//               ref_sensor_id; per other sensor: int32 type, uint32 id,
//               uint8 has_pose, [float64 qw, qx, qy, qz, tx, ty, tz
//               (sensor_from_rig)].
//   frames.bin: uint64 num_frames; per frame: uint32 frame_id, uint32 rig_id,
//               float64 qw, qx, qy, qz, tx, ty, tz (rig_from_world), uint32
//               num_data_ids; per data: int32 sensor_type, uint32 sensor_id,
//               uint64 data_id (an image_id for a camera).
// images.bin keeps its 3.8 layout in every release (an image's pose is
// written as its cam_from_world, composed from its frame and rig); from 3.12
// COLMAP links images to frames through frames.bin, so the two must be kept
// together: a model without them is read as one rig per camera and one frame
// per image.
#pragma once

#include <Eigen/Core>
#include <map>
#include <optional>
#include <string>
#include <vector>

#include "hisfm/io/rigs.h"
#include "hisfm/util/rigid3d.h"
#include "hisfm/util/types.h"

namespace hisfm {

/// Intrinsics of one camera; model ids and parameter orders are COLMAP's.
struct Camera {
  CameraId camera_id = kInvalidCameraId;
  int model_id = -1;
  uint64_t width = 0;
  uint64_t height = 0;
  std::vector<double> params;
};

/// A keypoint of a registered image and the 3D point it observes, if any.
struct Point2D {
  Eigen::Vector2d xy = Eigen::Vector2d::Zero();
  Point3DId point3D_id = kInvalidPoint3DId;
};

/// A registered image.
struct Image {
  ImageId image_id = kInvalidImageId;
  CameraId camera_id = kInvalidCameraId;
  std::string name;
  Rigid3d cam_from_world;
  std::vector<Point2D> points2D;

  /// Camera centre in world coordinates.
  Eigen::Vector3d ProjectionCenter() const {
    return cam_from_world.Inverse().translation;
  }
};

/// One observation of a 3D point.
struct TrackElement {
  ImageId image_id = kInvalidImageId;
  Point2DIdx point2D_idx = 0;
};

/// A triangulated 3D point with its colour, mean reprojection error and track.
struct Point3D {
  Eigen::Vector3d xyz = Eigen::Vector3d::Zero();
  Eigen::Matrix<uint8_t, 3, 1> color = Eigen::Matrix<uint8_t, 3, 1>::Zero();
  double error = -1.0;
  std::vector<TrackElement> track;
};

/// The order in which a model's records appeared in the files it was read
/// from. COLMAP keeps cameras, images and points in hash maps and writes them
/// in the maps' iteration order, so files are not sorted by id. Keeping the
/// order lets WriteModelBinary reproduce a file byte for byte, and lets
/// WriteModelText list the records in the order `colmap model_converter`
/// would. Ids no longer in the model are skipped when writing; ids missing
/// from the order (records added in memory) follow in increasing id order.
/// Models built in memory may leave it empty.
struct ModelFileOrder {
  std::vector<CameraId> cameras;
  std::vector<ImageId> images;
  std::vector<Point3DId> points3D;
};

/// A sparse model: what COLMAP writes into one numbered model folder.
struct Reconstruction {
  std::map<CameraId, Camera> cameras;
  std::map<ImageId, Image> images;
  std::map<Point3DId, Point3D> points3D;
  /// Record order of the files this model was read from (see ModelFileOrder).
  ModelFileOrder file_order;
  /// The rigs and frames of rigs.bin / frames.bin (or .txt), in file order;
  /// absent when the model had no such file (before COLMAP 3.12, or built
  /// in memory). Kept so that a model hisfm rewrites keeps them.
  std::optional<std::vector<Rig>> rigs;
  std::optional<std::vector<Frame>> frames;

  /// The image with this name, or nullptr.
  const Image* FindImageWithName(const std::string& name) const;
  size_t NumRegImages() const { return images.size(); }
  size_t NumPoints3D() const { return points3D.size(); }
  /// Mean number of observations per 3D point (0 without points).
  double MeanTrackLength() const;
  /// Mean of the points' stored reprojection errors (0 without points).
  double MeanReprojectionError() const;
  /// Total number of observations over all points.
  size_t NumObservations() const;
};

/// Number of parameters of a COLMAP camera model, or -1 if unknown.
int CameraModelNumParams(int model_id);
/// Number of focal lengths of a COLMAP camera model (1: f, 2: fx and fy;
/// they are its first parameters), or 0 if unknown.
int CameraModelNumFocalLengths(int model_id);
/// COLMAP's name of a camera model ("SIMPLE_RADIAL"), or "" if unknown.
std::string CameraModelIdToName(int model_id);
/// Model id for a COLMAP model name, or -1 if unknown.
int CameraModelNameToId(const std::string& name);

/// True if `path` is a folder holding a model (cameras.bin or cameras.txt).
bool HasModel(const std::string& path);
/// The numbered sub-folders of `folder` (0, 1, 2, ... as colmap mapper
/// writes them) that hold a model, in numeric order; empty if there is none
/// or `folder` cannot be read.
std::vector<std::string> NumberedModelFolders(const std::string& folder);
/// The model folders that make up a result at `model_path`: the folder
/// itself, or all numbered folders beside it if it is one of several (out/0
/// of out/0, out/1), or the numbered folders inside it (a COLMAP `sparse`
/// folder). Throws hisfm::Error if there is none.
std::vector<std::string> ResultModelFolders(const std::string& model_path);
/// Reads a model folder, binary if cameras.bin is there, else text; throws
/// hisfm::Error with a one-line message if it is missing or malformed, or
/// has a problem of hisfm/io/model_validation.h (the first one is named).
Reconstruction ReadModel(const std::string& path);
/// ReadModel of the binary files (cameras.bin, images.bin, points3D.bin).
Reconstruction ReadModelBinary(const std::string& path);
/// ReadModel of the text files (cameras.txt, images.txt, points3D.txt).
Reconstruction ReadModelText(const std::string& path);
/// ReadModel without the checks of model_validation.h (the file format is
/// still checked): for listing a model's problems.
Reconstruction ReadModelUnvalidated(const std::string& path);
/// Reads the numbered models folder/0, folder/1, ... that colmap mapper
/// writes, in that order, stopping at the first missing number; empty if
/// there is none.
std::vector<Reconstruction> ReadNumberedModels(const std::string& folder);
/// Writes cameras.bin, images.bin and points3D.bin (and rigs.bin and
/// frames.bin if the model has them) into an existing folder, each file
/// through a temporary file and a rename. Records are written in
/// model.file_order and values exactly as stored, so a binary model read and
/// written again is byte-identical. (COLMAP itself would re-normalize the
/// quaternions and write its hash-map order instead.)
void WriteModelBinary(const Reconstruction& model, const std::string& path);
/// Writes cameras.txt, images.txt and points3D.txt (and rigs.txt and
/// frames.txt if the model has them, by increasing id as COLMAP does) into
/// an existing folder, each file through a temporary file and a rename. The text is byte-identical
/// to what `colmap model_converter --output_type TXT` writes from the files
/// the model was read from (or from WriteModelBinary's output): COLMAP's
/// headers, 17 significant digits, quaternions normalized as COLMAP does on
/// reading and again on writing, records in the iteration order of COLMAP's
/// hash maps filled in model.file_order.
void WriteModelText(const Reconstruction& model, const std::string& path);

}  // namespace hisfm
