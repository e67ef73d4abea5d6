// Per-image and per-pair geometry read lazily from a COLMAP database and
// kept for the multi-view checks: keypoints (pixels and normalized), a grid
// over them, each pair's inlier correspondences and its robust relative pose
// hypotheses (relative_pose.h).
#pragma once

#include <Eigen/Core>
#include <memory>
#include <mutex>
#include <unordered_map>
#include <vector>

#include "hisfm/graph/view_graph.h"
#include "hisfm/io/database.h"
#include "hisfm/verify/camera_projection.h"
#include "hisfm/verify/keypoint_grid.h"
#include "hisfm/verify/relative_pose.h"

namespace hisfm {

struct GeometryCacheOptions {
  /// Radius (pixels) of the keypoint grid's queries: a projected point is
  /// "found" in an image if a keypoint lies this close.
  double keypoint_radius_px = 3.0;
  /// Robust relative pose estimation of each pair.
  RelativePoseOptions relative_pose;

  /// Throws hisfm::Error if an option is out of range.
  void Check() const;
};

/// Everything an image contributes.
struct ImageGeometry {
  ImageId image_id = kInvalidImageId;
  CameraProjection camera;
  /// Keypoints in pixels and undistorted normalized coordinates.
  std::vector<Eigen::Vector2d> pixels;
  std::vector<Eigen::Vector2d> normalized;
  KeypointGrid grid;
  /// Per keypoint, the number of verified pairs it is an inlier of (empty
  /// unless the cache was given degrees).
  std::vector<uint16_t> degree;
};

/// A pair's inliers and poses, oriented from `from` to `to` (as asked).
struct PairGeometry {
  ImageId from = kInvalidImageId;
  ImageId to = kInvalidImageId;
  /// Inlier correspondences: keypoint of `from`, keypoint of `to`.
  std::vector<FeatureMatch> matches;
  /// Keypoint of `to` matched to each keypoint of `from` (kNoMatch if
  /// none), and back.
  std::vector<int32_t> from_to;
  std::vector<int32_t> to_from;
  /// Relative pose hypotheses to_from_from (unit baseline), best first; at
  /// most one per translation sign; empty if none could be estimated.
  std::vector<RelativePoseHypothesis> hypotheses;
  static constexpr int32_t kNoMatch = -1;
};

/// Lazily reads and caches image and pair geometry. Safe to use from several
/// threads at once: the database is read under a lock, and a pair's poses are
/// estimated outside it (two threads asking for the same new pair may both
/// estimate it; the estimate is seeded by the pair, so both are the same and
/// the first stored is kept). The lock is the cache's own: the database must
/// not be used elsewhere while the cache is (io/database.h: one thread per
/// Database). The database and the graph must outlive the cache.
class GeometryCache {
 public:
  /// `graph` names the pairs that exist (its edges, any weight).
  GeometryCache(const Database& database, const ViewGraph& graph,
                const GeometryCacheOptions& options = {});

  /// Keypoint degrees (match_burstiness.h) to attach to the images; call
  /// before the first Image().
  void SetKeypointDegrees(
      std::unordered_map<ImageId, std::vector<uint16_t>> degrees) {
    std::lock_guard<std::mutex> lock(mutex_);
    degrees_ = std::move(degrees);
  }
  /// The image's geometry (throws hisfm::Error for an unknown image).
  const ImageGeometry& Image(ImageId image_id);
  /// True if the pair is an edge of the graph.
  bool HasPair(ImageId a, ImageId b) const;
  /// The pair oriented from `a` to `b` (throws hisfm::Error if absent).
  /// Poses are estimated on first use.
  std::shared_ptr<const PairGeometry> Pair(ImageId a, ImageId b);
  const GeometryCacheOptions& options() const { return options_; }

 private:
  // The stored orientation (smaller id first), poses included.
  std::shared_ptr<const PairGeometry> Stored(const ImagePair& pair);
  // Image() with mutex_ held.
  const ImageGeometry& ImageLocked(ImageId image_id);

  const Database& database_;
  const ViewGraph& graph_;
  GeometryCacheOptions options_;
  // Guards the database and the maps below (an ImageGeometry and a
  // PairGeometry do not change once stored).
  std::mutex mutex_;
  std::unordered_map<CameraId, DatabaseCamera> cameras_;
  std::unordered_map<ImageId, CameraId> camera_of_image_;
  std::unordered_map<ImageId, std::unique_ptr<ImageGeometry>> images_;
  std::unordered_map<ImageId, std::vector<uint16_t>> degrees_;
  std::unordered_map<ImagePair, std::shared_ptr<const PairGeometry>,
                     ImagePairHash>
      stored_;
  // Reversed orientations, made on demand.
  std::unordered_map<ImagePair, std::shared_ptr<const PairGeometry>,
                     ImagePairHash>
      reversed_;
};

}  // namespace hisfm
