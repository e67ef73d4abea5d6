// Read-only access to a COLMAP database (SQLite), as written by COLMAP 3.8
// to 4.1.
//
// Format (COLMAP 3.8, src/base/database.cc):
//   cameras(camera_id, model, width, height, params BLOB of float64,
//           prior_focal_length)
//   images(image_id, name UNIQUE, camera_id, prior_q*, prior_t*)
//   keypoints(image_id, rows, cols, data BLOB of float32, rows x cols,
//             row-major; cols is 2 (x, y), 4 (x, y, scale, orientation) or
//             6 (x, y, a11, a12, a21, a22))
//   descriptors(image_id, rows, cols=128, data BLOB of uint8)
//   matches(pair_id, rows, cols=2, data BLOB of uint32 point2D indices)
//   two_view_geometries(pair_id, rows, cols=2, data (inlier matches), config,
//           F, E, H (float64 3x3, row-major), qvec (float64 w,x,y,z),
//           tvec (float64 x,y,z))
// pair_id is ImagePairToPairId (hisfm/util/types.h); matches are stored with
// the first column indexing the image with the smaller id. `rows` of a
// two_view_geometries row is its number of inliers. Keypoint coordinates use
// COLMAP's convention: the centre of the upper-left pixel is (0.5, 0.5).
//
// Later releases (src/colmap/scene/database.cc, from 3.13
// database_sqlite.cc; DatabaseLayout tells them apart):
//   3.10: images lose their prior_* columns; pose_priors(image_id, position
//         BLOB 3 float64, coordinate_system);
//   3.11: pose_priors.position_covariance (BLOB 9 float64);
//   3.12: rigs(rig_id, ref_sensor_id, ref_sensor_type), rig_sensors(rig_id,
//         sensor_id, sensor_type, sensor_from_rig BLOB 7 float64 qw qx qy qz
//         tx ty tz), frames(frame_id, rig_id), frame_data(frame_id, data_id,
//         sensor_id, sensor_type);
//   4.0:  pose_priors(pose_prior_id, corr_data_id, corr_sensor_id,
//         corr_sensor_type, position, position_covariance, gravity,
//         coordinate_system); descriptors.type (0 SIFT; ALIKED rows are its
//         float32 descriptors as bytes); unknown F, E, H, qvec and tvec are
//         NULL (read as zero), and a verified pair may have no inliers.
// The tables and columns hisfm reads have the same meaning in every release.
#pragma once

#include <Eigen/Core>
#include <functional>
#include <limits>
#include <memory>
#include <string>
#include <unordered_map>
#include <vector>

#include "hisfm/io/rigs.h"
#include "hisfm/util/types.h"

struct sqlite3;

namespace hisfm {

/// A row of the `cameras` table.
struct DatabaseCamera {
  CameraId camera_id = kInvalidCameraId;
  int model_id = -1;  ///< COLMAP camera model id (0 = SIMPLE_PINHOLE, ...).
  uint64_t width = 0;
  uint64_t height = 0;
  std::vector<double> params;
  bool prior_focal_length = false;
};

/// A SIMPLE_PINHOLE camera (model 0) of the given size and focal length
/// (pixels), principal point at the image centre.
DatabaseCamera SimplePinholeCamera(CameraId camera_id, uint64_t width,
                                   uint64_t height, double focal_length);

/// The optional tables and columns of a database, which differ between the
/// COLMAP releases that wrote it (see the top of this file).
struct DatabaseLayout {
  /// images.prior_qw ... prior_tz (3.8, 3.9).
  bool image_prior_columns = false;
  /// A pose_priors table (3.10 and later).
  bool pose_priors = false;
  /// pose_priors.position_covariance (3.11 and later).
  bool position_covariance = false;
  /// pose_priors keyed by pose_prior_id, with corr_data_id, corr_sensor_id,
  /// corr_sensor_type and gravity (4.0 and later).
  bool pose_prior_ids = false;
  /// rigs, rig_sensors, frames and frame_data tables (3.12 and later).
  bool rigs_and_frames = false;
  /// descriptors.type (4.0 and later).
  bool descriptor_type = false;
  /// PRAGMA user_version (3.9 to 3.12 write 3900; later releases encode
  /// their version).
  int user_version = 0;

  /// The oldest COLMAP release that writes this layout ("3.8", "3.10",
  /// "3.11", "3.12" or "4.0").
  std::string OldestRelease() const;
};

/// A position prior of an image (`pose_priors`, 3.10 and later). Values
/// COLMAP leaves unknown are NaN.
struct DatabasePosePrior {
  /// The image it belongs to (4.0: corr_data_id of a camera sensor).
  ImageId image_id = kInvalidImageId;
  Eigen::Vector3d position =
      Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  Eigen::Matrix3d position_covariance =
      Eigen::Matrix3d::Constant(std::numeric_limits<double>::quiet_NaN());
  /// COLMAP's PosePrior::CoordinateSystem: -1 undefined, 0 WGS84,
  /// 1 Cartesian.
  int coordinate_system = -1;
  /// The gravity direction in the camera frame (4.0 and later).
  Eigen::Vector3d gravity =
      Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
};

/// A row of the `images` table (priors are not used by HiSfM).
struct DatabaseImage {
  ImageId image_id = kInvalidImageId;
  std::string name;
  CameraId camera_id = kInvalidCameraId;
};

/// One correspondence between keypoint idx1 of the first image and keypoint
/// idx2 of the second image of a pair.
struct FeatureMatch {
  Point2DIdx idx1 = 0;
  Point2DIdx idx2 = 0;
};

/// A read-only run of feature matches that it does not own: valid only as
/// long as the storage it views (for a callback argument, during the call).
class FeatureMatchSpan {
 public:
  /// An empty span.
  FeatureMatchSpan() = default;
  /// The `size` matches from `data`.
  FeatureMatchSpan(const FeatureMatch* data, size_t size)
      : data_(data), size_(size) {}
  /// Views a whole vector (implicit, so vectors pass where spans are taken;
  /// a span of a temporary vector lives only until the end of the
  /// expression that made it).
  FeatureMatchSpan(const std::vector<FeatureMatch>& matches)  // NOLINT
      : data_(matches.data()), size_(matches.size()) {}
  /// First match, and one past the last.
  const FeatureMatch* begin() const { return data_; }
  const FeatureMatch* end() const { return data_ + size_; }
  /// Match i (i < size()).
  const FeatureMatch& operator[](size_t i) const { return data_[i]; }
  /// Number of matches.
  size_t size() const { return size_; }
  /// True if there are none.
  bool empty() const { return size_ == 0; }

 private:
  const FeatureMatch* data_ = nullptr;
  size_t size_ = 0;
};

/// COLMAP's TwoViewGeometry::ConfigurationType values.
enum class TwoViewConfig : int {
  kUndefined = 0,
  kDegenerate = 1,
  kCalibrated = 2,
  kUncalibrated = 3,
  kPlanar = 4,
  kPanoramic = 5,
  kPlanarOrPanoramic = 6,
  kWatermark = 7,
  kMultiple = 8,
};

/// Summary of a verified pair: enough to build the view graph. (The config
/// column is not read here: it sits behind the match blob, and reaching it
/// costs a read of every overflow page.)
struct VerifiedPair {
  ImagePair pair;
  uint32_t num_inliers = 0;
};

/// A full row of `two_view_geometries`, oriented as stored (pair.image_id1 is
/// the smaller id; matches index its keypoints first).
struct TwoViewGeometry {
  ImagePair pair;
  int config = 0;
  std::vector<FeatureMatch> inlier_matches;
  Eigen::Matrix3d F = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d E = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
  /// cam2_from_cam1 rotation (w, x, y, z); zero when COLMAP did not store one.
  Eigen::Vector4d qvec = Eigen::Vector4d::Zero();
  Eigen::Vector3d tvec = Eigen::Vector3d::Zero();
};

/// Keypoint locations of one image, one row (x, y) per keypoint.
using Keypoints = Eigen::Matrix<float, Eigen::Dynamic, 2, Eigen::RowMajor>;
/// SIFT descriptors of one image, one row of 128 bytes per keypoint.
using Descriptors =
    Eigen::Matrix<uint8_t, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

/// A COLMAP database opened read-only: the input is never modified. All
/// readers throw hisfm::Error with a one-line message on failure.
class Database {
 public:
  /// Opens `path` read-only and checks that it has COLMAP's tables.
  explicit Database(const std::string& path);
  ~Database();
  Database(const Database&) = delete;
  Database& operator=(const Database&) = delete;

  const std::string& path() const { return path_; }

  /// Every camera, by id.
  std::vector<DatabaseCamera> ReadCameras() const;
  /// Every image, by id.
  std::vector<DatabaseImage> ReadImages() const;
  /// Which optional tables and columns the file has.
  DatabaseLayout Layout() const;
  /// Every position prior, by image id (empty before 3.10; the image prior
  /// columns of 3.8 and 3.9 are not read). 4.0 priors of other sensors than
  /// cameras are left out.
  std::vector<DatabasePosePrior> ReadPosePriors() const;
  /// Every rig, by id, with its sensors (empty before 3.12).
  std::vector<Rig> ReadRigs() const;
  /// Every frame, by id, with its data (empty before 3.12; databases hold no
  /// frame poses).
  std::vector<Frame> ReadFrames() const;
  /// Number of rows in `two_view_geometries` with at least `min_num_inliers`.
  size_t NumVerifiedPairs(uint32_t min_num_inliers = 1) const;
  /// Every verified pair with at least `min_num_inliers` inliers, sorted by
  /// pair. Reads only the pair id and row count, but rows of a few hundred
  /// inliers fill a page each, so this scans the whole table: two threads
  /// (two read-only connections) take turns at 64 chunks of first image ids.
  std::vector<VerifiedPair> ReadVerifiedPairs(uint32_t min_num_inliers) const;
  /// The full two-view geometry of a pair; throws if the pair is absent.
  TwoViewGeometry ReadTwoViewGeometry(ImageId a, ImageId b) const;
  /// Only the inlier matches of a pair, oriented as stored (the first column
  /// indexes the image with the smaller id); throws if the pair is absent.
  /// Cheaper than ReadTwoViewGeometry when the matrices are not needed.
  std::vector<FeatureMatch> ReadInlierMatches(ImageId a, ImageId b) const;
  /// Reads the inlier matches of many pairs in ascending pair-id order
  /// (sequential page access, one prepared statement, one read transaction)
  /// and calls `fn(pair, matches)` for each, on the calling thread, the pair
  /// oriented as stored (the span is valid during the call only); pairs
  /// absent from the database are skipped, duplicates read once. From 4,096
  /// pairs on, a second read-only connection (its own snapshot, outside any
  /// ReadScope of this one) reads ahead on its own thread while `fn` runs.
  /// `on_read`, if set, is called
  /// with each pair as it is read, before `fn` gets it and in the same
  /// order, on that reading thread when there is one: concurrently with
  /// `fn`, so the two must not share unsynchronized state (work on the
  /// matches that needs nothing from `fn` thus runs on the second core). An
  /// exception thrown by `fn`, `on_read` or the reading stops both and
  /// reaches the caller.
  void ForEachInlierMatches(
      std::vector<ImagePair> pairs,
      const std::function<void(const ImagePair&, FeatureMatchSpan)>& fn,
      const std::function<void(const ImagePair&, FeatureMatchSpan)>& on_read =
          nullptr) const;
  /// Number of keypoints of every image that has a keypoints row (reads only
  /// the row counts, not the keypoint data).
  std::unordered_map<ImageId, size_t> ReadNumKeypoints() const;
  /// Raw (putative) matches of a pair, oriented like the stored pair; empty if
  /// absent.
  std::vector<FeatureMatch> ReadMatches(ImageId a, ImageId b) const;
  /// Keypoint locations of an image (x, y); empty if absent.
  Keypoints ReadKeypoints(ImageId image_id) const;
  /// Descriptors of an image; empty if absent.
  Descriptors ReadDescriptors(ImageId image_id) const;

  /// While a ReadScope of a database lives, its reads share one read
  /// transaction instead of locking the file once per statement (many small
  /// reads get several times faster). Scopes nest. Writers of the file wait
  /// until the outermost scope ends.
  class ReadScope {
   public:
    explicit ReadScope(const Database& database);
    ~ReadScope();
    ReadScope(const ReadScope&) = delete;
    ReadScope& operator=(const ReadScope&) = delete;

   private:
    const Database& database_;
  };

  // Reads reuse prepared statements, so one Database must not be used from
  // two threads at once (open one per thread instead).

 private:
  struct CachedStatements;
  void BeginRead() const;
  void EndRead() const;

  std::string path_;
  sqlite3* db_ = nullptr;
  std::unique_ptr<CachedStatements> statements_;
  mutable int read_depth_ = 0;
};

/// What WriteFilteredDatabase copies besides cameras, images and keypoints.
struct FilteredDatabaseOptions {
  /// Copy the descriptors table (COLMAP's mapper does not read it), if the
  /// source has one.
  bool copy_descriptors = false;
  /// Copy raw matches of the kept pairs (the mapper does not read them), if
  /// the source has a matches table.
  bool copy_matches = false;
  /// If set, the kept pairs it holds get these inlier matches (oriented as
  /// stored: the smaller image id's keypoints first) instead of the
  /// source's; F, E, H and the configuration are copied unchanged. Not
  /// owned; must outlive the call.
  const std::unordered_map<ImagePair, std::vector<FeatureMatch>,
                           ImagePairHash>* replace_inliers = nullptr;

  void Check() const {}
};

/// Writes a new COLMAP database at `output_path` in the source's own schema
/// (its tables, indexes and user_version, plus any COLMAP 3.8 table it
/// lacks), with every row of every table but these: only the `keep` pairs of
/// two_view_geometries, and no descriptors or matches unless asked (then
/// only the kept pairs' matches). Newer releases' tables (pose priors, rigs,
/// frames) thus reach colmap unchanged. The source is attached read-only;
/// the output is written to a temporary file and renamed into place.
void WriteFilteredDatabase(const std::string& source_path,
                           const std::string& output_path,
                           const std::vector<ImagePair>& keep,
                           const FilteredDatabaseOptions& options = {});

/// COLMAP 3.8's CREATE TABLE statements, in order.
const std::vector<std::string>& ColmapSchemaStatements();

}  // namespace hisfm
