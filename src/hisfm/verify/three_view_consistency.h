// Three-view consistency of a pair's inliers with the structure that one of
// its images shares with a third image.
//
// A two-view geometry fixes the relative pose of a pair only up to the
// length (and sign) of its baseline, so a doppelganger pair can carry the
// right epipolar geometry: in a street of identical houses, photos taken a
// few houses apart match the unique ground truly and the repeated facades
// falsely, and both groups agree with one essential matrix. Such a mixed pair
// is exposed by a third view (the classic test of track and loop consistency,
// e.g. Zach, Klopschitz, Pollefeys, "Disambiguating Visual Relations Using
// Loop Constraints", CVPR 2010, and the missing-correspondence reasoning of
// Zach, Irschara, Bischof, CVPR 2008): for a pair (x, y) and a third image t
// matched to x,
//   1. the pair (x, t) triangulates the keypoints of x that it shares with
//      (x, y) (in x's frame, unit baseline; points seen under a small
//      triangulation angle are skipped);
//   2. the baseline scale of (x, y) relative to (x, t) is the median of the
//      per-point scales of the *distinctive* shared keypoints
//      (track_consistency.h), which true matches of unique content fix;
//   3. each shared keypoint is triangulated from the three views (x, t and
//      y placed at that scale) and is consistent if it reprojects within
//      max_error_px in all three.
// The consistent fraction is about 1 for a true pair and about the
// distinctive fraction for a mixed pair, whose repeated matches disagree
// with the scale its unique matches fix. Without enough distinctive shared
// keypoints the test is silent. A pure doppelganger of a rigid symmetry is
// consistent (its matches describe one rigid, if wrong, placement); the
// distinctive-support and coverage cues deal with those.
#pragma once

#include <Eigen/Core>
#include <memory>
#include <mutex>
#include <unordered_map>
#include <vector>

#include "hisfm/io/database.h"
#include "hisfm/util/rigid3d.h"
#include "hisfm/util/types.h"
#include "hisfm/verify/camera_projection.h"
#include "hisfm/verify/track_consistency.h"

namespace hisfm {

struct ThreeViewOptions {
  /// A shared keypoint is consistent if its three-view triangulation
  /// reprojects within this many pixels in each image (COLMAP's default
  /// two-view max_error).
  double max_error_px = 4.0;
  /// Shared keypoints that (x, t) triangulates under a smaller angle
  /// (degrees) are skipped: their depth is too uncertain.
  double min_triangulation_angle_deg = 1.0;
  /// The test is silent with fewer distinctive shared keypoints fixing the
  /// scale.
  int min_scale_points = 5;
  /// The consistent fraction is counted on at most this many shared
  /// keypoints, evenly spaced by keypoint index; every distinctive shared
  /// keypoint still fixes the scale, so whether the test judges does not
  /// change. The fraction of 100 points has a standard error of at most 5
  /// points, against a decision threshold of 50%; 0 counts all of them.
  int max_shared_points = 100;

  /// Throws hisfm::Error if an option is out of range.
  void Check() const;
};

/// Outcome of one three-view test.
struct ThreeViewResult {
  /// Shared keypoints of x (inliers of both pairs) that were triangulated
  /// (0 when too few distinctive ones left nothing to triangulate for).
  int num_shared = 0;
  /// Distinctive ones among them, which fixed the scale.
  int num_scale_points = 0;
  /// Shared keypoints consistent in all three views.
  int num_consistent = 0;
  /// True if there were enough scale points to judge.
  bool judged = false;
  /// num_consistent / num_shared (1 when not judged).
  double fraction = 1.0;
};

/// Normalized keypoints and relative poses of a database's images and
/// pairs, read lazily and cached (the pose of a pair is recovered from its
/// stored geometry, two_view_pose.h). Safe to use from several threads at
/// once: their reads of the database take turns, their computations do
/// not.
class PairGeometryCache {
 public:
  /// The database must outlive the cache.
  explicit PairGeometryCache(const Database& database);

  /// A pair's inliers as keypoint maps and its relative pose.
  struct PairGeometry {
    ImagePair pair;
    /// False if no pose could be recovered.
    bool has_pose = false;
    /// cam2_from_cam1 of pair.image_id1 -> pair.image_id2, unit baseline.
    Rigid3d cam2_from_cam1;
    /// Keypoint of image 2 matched to each keypoint of image 1 (indexed by
    /// keypoint, kNoMatch if none), and back.
    std::vector<int32_t> to2;
    std::vector<int32_t> to1;
    static constexpr int32_t kNoMatch = -1;
  };

  /// The pair's geometry (throws hisfm::Error if the pair is absent). With
  /// `keep` false the result is not cached (a pair that is tested once).
  std::shared_ptr<const PairGeometry> Pair(const ImagePair& pair,
                                           bool keep = true);
  /// Undistorted normalized image coordinates of an image's keypoints.
  const std::vector<Eigen::Vector2d>& Normalized(ImageId image_id);
  /// Mean focal length (pixels) of an image's camera.
  double Focal(ImageId image_id);

 private:
  const Database& database_;
  // Guards the two caches below; read_mutex_ the database's connection.
  std::mutex mutex_;
  std::mutex read_mutex_;
  std::unordered_map<CameraId, CameraProjection> cameras_;
  std::unordered_map<ImageId, CameraId> camera_of_image_;
  std::unordered_map<ImageId, std::vector<Eigen::Vector2d>> normalized_;
  std::unordered_map<ImagePair, std::shared_ptr<const PairGeometry>,
                     ImagePairHash>
      pairs_;
};

/// The three-view test of the pair `xy` seen from its image x through the
/// third image t (x must be an image of `xy`, the pair (x, t) must be in the
/// database; see the file comment). Not judged if `xy` or (x, t) has no
/// pose.
ThreeViewResult MeasureThreeViewConsistency(
    PairGeometryCache& cache, const TrackConsistency& tracks,
    const PairGeometryCache::PairGeometry& xy, ImageId x, ImageId t,
    const ThreeViewOptions& options);

}  // namespace hisfm
