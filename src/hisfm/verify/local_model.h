// Local three-view models around an image, the context in which HiSfM's
// multi-view checks judge the image's pairs.
//
// Two views cannot tell a true pair from one whose matches join two copies of
// repeated structure when both groups satisfy the same epipolar geometry
// (relative_pose.h); a third view can, because a match to the wrong copy
// does not land on the same point once the scale of the baselines is fixed
// (the three-view tests of Zach, Klopschitz, Pollefeys, "Disambiguating
// Visual Relations Using Loop Constraints", CVPR 2010), and a pair of views
// placed at the wrong distance predicts structure that the third view does
// not show (missing correspondences: Zach, Irschara, Bischof, "What Can
// Missing Correspondences Tell Us About 3D Structure and Motion?", CVPR
// 2008). A triplet model is the ego image with two of its strongest
// neighbours: the two pair poses (each with its translation sign chosen by
// the model, not by one pair's majority), the scale between them from the
// depths of the keypoints the pairs share, and the points that reproject
// within max_reprojection_px in all three views. Its consistency is the
// share of points seen in two views, predicted visible in the third, that
// land on a keypoint there. The ego model is the most consistent well-
// supported triplet among the image's strongest neighbours.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "hisfm/graph/view_graph.h"
#include "hisfm/util/rigid3d.h"
#include "hisfm/verify/geometry_cache.h"

namespace hisfm {

/// When a point seen from one camera should be detected again from another:
/// a feature detector and descriptor tolerate a limited change of scale and
/// of viewing direction (SIFT: a factor of about 2, some 40 degrees; Lowe,
/// IJCV 2004, Sec. 9). Beyond that a point is not expected to be found, and
/// its absence says nothing.
struct VisibilityOptions {
  /// Largest ratio of the point's distances to the two cameras.
  double max_scale_change = 2.0;
  /// Largest angle (degrees) between the two viewing rays at the point.
  double max_view_angle_deg = 40.0;

  /// Throws hisfm::Error if an option is out of range.
  void Check() const;
};

struct LocalModelOptions {
  /// The ego image's strongest pairs whose other images are tried as the
  /// model's two other views.
  int num_candidates = 4;
  /// A point belongs to the model if it reprojects within this many pixels
  /// in each of the three views.
  double max_reprojection_px = 2.0;
  /// Shared keypoints needed to fix the scale between the two pairs, and
  /// points needed to form a model.
  int min_points = 5;
  /// When a point is predicted visible in a view.
  VisibilityOptions visibility;
  /// Two-view points seen under a smaller triangulation angle (degrees) are
  /// too uncertain in depth to be predicted into the third view.
  double min_triangulation_angle_deg = 2.0;
  /// Side (pixels) of the square cells on which a model's coverage of the
  /// ego image is counted.
  double coverage_cell_px = 64;
  /// Refine the chosen triplet by bundle adjustment (Ceres) before its
  /// points are used for predictions.
  bool bundle_adjust = true;
  /// Also keep the two-view points (ego and one other view) whose keypoints
  /// are distinctive: inliers of at most distinctive_degree_fraction of the
  /// median number of pairs the ego image's matched keypoints are inliers
  /// of (at least 2). Unique content near the cameras (clutter, the ground)
  /// is often seen in two views only; repeated structure, and the phantom
  /// points its wrong matches triangulate, is matched by many pairs.
  bool distinctive_two_view_points = true;
  double distinctive_degree_fraction = 0.5;

  /// Throws hisfm::Error if an option is out of range.
  void Check() const;
};

/// A small reconstruction in the ego image's frame (scale: unit baseline to
/// images[1]).
struct LocalModel {
  /// images[0] is the ego image.
  std::vector<ImageId> images;
  /// Pose of each image; images[0] at the identity.
  std::vector<Rigid3d> cam_from_model;
  std::vector<Eigen::Vector3d> points;
  /// keypoints[v][p]: the keypoint of images[v] that observes point p, or
  /// kNoKeypoint (only for v > 0: the ego image observes every point).
  std::vector<std::vector<uint32_t>> keypoints;
  static constexpr uint32_t kNoKeypoint = UINT32_MAX;
  /// Two-view points predicted visible in the third view, and those that
  /// landed on a keypoint.
  int num_checked = 0;
  int num_found = 0;
  /// Cells of the ego image (LocalModelOptions::coverage_cell_px) holding a
  /// keypoint of a point.
  int num_cells = 0;

  bool empty() const { return points.empty(); }
  /// num_found / num_checked (1 when nothing was checked).
  double Consistency() const;
  /// Index of an image in `images`, or -1.
  int IndexOf(ImageId image_id) const;
};

/// Projects `point` (in the frame that `target_from_frame` maps from) into
/// `target` and tells whether it should be detected there: in front,
/// inside the image, and within `visibility`'s limits of scale and viewing
/// direction relative to the camera at `observer_center` (same frame) that
/// saw it. Writes the pixel when visible.
bool PredictVisible(const ImageGeometry& target,
                    const Rigid3d& target_from_frame,
                    const Eigen::Vector3d& point,
                    const Eigen::Vector3d& observer_center,
                    const VisibilityOptions& visibility,
                    Eigen::Vector2d* pixel);

/// The triplet model of `ego` with `a` and `c`, using pose hypothesis
/// `hypothesis_a` of (ego, a) and `hypothesis_c` of (ego, c) (indices into
/// PairGeometry::hypotheses). Empty if a hypothesis is missing, the scale
/// cannot be fixed, or fewer than min_points points agree.
LocalModel BuildTripletModel(GeometryCache& cache, ImageId ego, ImageId a,
                             ImageId c, int hypothesis_a, int hypothesis_c,
                             const LocalModelOptions& options);

/// Refines a model's poses and points by bundle adjustment (reprojection
/// error, Huber loss; the ego camera fixed and the baseline to images[1]
/// kept at unit length), then drops points that still reproject worse than
/// max_reprojection_px in a view.
void BundleAdjustModel(GeometryCache& cache, const LocalModelOptions& options,
                       LocalModel* model);

/// Recounts the model's internal consistency (LocalModel::num_checked,
/// num_found): the two-view points of its pairs with the ego image,
/// predicted into the third view.
void CheckModelConsistency(GeometryCache& cache,
                           const LocalModelOptions& options,
                           LocalModel* model);

/// The ego model of `ego`: among the triplets of ego with two of its
/// num_candidates strongest neighbours in `graph` (other than `exclude`,
/// which may be kInvalidImageId) and every combination of their pose
/// hypotheses, the one whose points cover the most cells of the ego image
/// (then: the most points), refined by bundle adjustment. A triplet of true
/// neighbours shares the scene's unique content, spread over the image, as
/// well as its repeated structure; a triplet joined through a doppelganger
/// shares only the latter, often the same number of points on a smaller part
/// of the image (the print of a symmetric object). Empty if no triplet
/// forms.
LocalModel BuildEgoModel(GeometryCache& cache, const ViewGraph& graph,
                         ImageId ego, ImageId exclude,
                         const LocalModelOptions& options);

/// The ego model of `ego` from triplets over `candidates` (its neighbours,
/// strongest first); BuildEgoModel uses its num_candidates strongest.
LocalModel BuildEgoModelFrom(GeometryCache& cache, ImageId ego,
                             const std::vector<ImageId>& candidates,
                             const LocalModelOptions& options);

/// The side of `ego` when the pair (ego, other) is tested: the `count`
/// strongest neighbours of `ego` in `graph`, leaving out `other` and every
/// neighbour x that belongs to the other side, w(ego, x) < other_side_ratio
/// * w(other, x). Heinly et al. (ECCV 2014) split a reconstruction into two
/// camera groups before comparing them; a model that holds images of the
/// other side shares their points with it (they are no longer unique, and
/// the test has little to predict), and an image glued to the other place
/// by doppelgangers of its own would be modelled in that place. Neighbours
/// that both images see about equally (the images between two true
/// neighbours along a path) stay on both sides: taking them from one would
/// leave its model to weaker, often repeated, neighbours. With
/// other_side_ratio <= 1 no neighbour leaves both sides.
std::vector<ImageId> SideNeighbours(const ViewGraph& graph, ImageId ego,
                                    ImageId other, size_t count,
                                    double other_side_ratio);

}  // namespace hisfm
