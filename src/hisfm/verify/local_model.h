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
#include <vector>

#include "hisfm/graph/view_graph.h"
#include "hisfm/util/rigid3d.h"
#include "hisfm/verify/geometry_cache.h"

namespace hisfm {

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
  /// A point is predicted visible in a view only if its depth there is
  /// within this factor of its depth in the view that observed it (a
  /// feature detector's scale tolerance).
  double max_scale_change = 2.0;
  /// Two-view points seen under a smaller triangulation angle (degrees) are
  /// too uncertain in depth to be predicted into the third view.
  double min_triangulation_angle_deg = 2.0;
  /// Refine the chosen triplet by bundle adjustment (Ceres) before its
  /// points are used for predictions.
  bool bundle_adjust = true;

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
  /// keypoints[v][p]: the keypoint of images[v] that observes point p.
  std::vector<std::vector<uint32_t>> keypoints;
  /// Two-view points predicted visible in the third view, and those that
  /// landed on a keypoint.
  int num_checked = 0;
  int num_found = 0;

  bool empty() const { return points.empty(); }
  /// num_found / num_checked (1 when nothing was checked).
  double Consistency() const;
  /// Index of an image in `images`, or -1.
  int IndexOf(ImageId image_id) const;
};

/// Projects `point` (in the frame that `target_from_frame` maps from) into
/// `target` and tells whether it should be visible there: in front, inside
/// the image, and at a depth within max_scale_change of `observed_depth`.
/// Writes the pixel when visible.
bool PredictVisible(const ImageGeometry& target,
                    const Rigid3d& target_from_frame,
                    const Eigen::Vector3d& point, double observed_depth,
                    double max_scale_change, Eigen::Vector2d* pixel);

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
/// hypotheses, the one with the most points (a triplet of true neighbours
/// shares the scene's unique content as well as its repeated structure; a
/// triplet joined through a doppelganger shares only the latter), refined
/// by bundle adjustment. Empty if no triplet forms.
LocalModel BuildEgoModel(GeometryCache& cache, const ViewGraph& graph,
                         ImageId ego, ImageId exclude,
                         const LocalModelOptions& options);

}  // namespace hisfm
