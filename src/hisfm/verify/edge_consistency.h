// The multi-view test of an image pair: do the local models around its two
// images agree once the pair joins them?
//
// Heinly, Dunn, Frahm, "Correcting for Duplicate Scene Structure in Sparse
// 3D Reconstruction", ECCV 2014, split a reconstruction along a camera
// spanning tree and flag a split whose two sides, joined, predict each
// other's unique structure where the other side does not see it. Here the
// sides are the ego models (local_model.h) of the pair's images i and j,
// each built from its image's own side of the pair (SideNeighbours), and
// the join is the pair itself: for each of its relative pose hypotheses
// the depths of the pair's inliers that are model points fix the scale of
// each model against the pair's baseline (their agreement measures how well
// the pair joins the models); the best-joining hypothesis places model j in
// model i's frame. A point of one model is unique if none of its keypoints
// is matched to an image of the other model; unique points predicted
// visible in the other model's images (local_model.h PredictVisible) should
// land on a keypoint there, unless the other model's own points show
// nearer structure at that place (occlusion). A true pair predicts what the other side sees;
// a doppelganger, which joins two places through their repeated structure,
// predicts one place's unique content (clutter, background, the print's
// surroundings) into the other's images, where nothing is found (missing
// correspondences, Zach et al. CVPR 2008; Cui & Tan ICCV 2015).
// The pair's inliers consistent with the joined geometry (supporting the
// hypothesis, and at the models' depth where they are model points) are
// reported too: they are the matches the reconstruction may use.
#pragma once

#include <vector>

#include "hisfm/verify/geometry_cache.h"
#include "hisfm/verify/local_model.h"

namespace hisfm {

struct EdgeTestOptions {
  /// Inliers of the pair that are model points and agree with the model's
  /// depth within this relative tolerance (once scaled) join the model.
  double depth_tolerance = 0.1;
  /// Each model must be joined by at least this many agreeing inliers.
  int min_join_points = 5;
  /// Refine the join (camera j's pose in model i's frame and model j's
  /// scale) by robust least squares of the reprojection errors of the
  /// pair's inliers that are model points, a 3D-to-2D fit that a planar
  /// scene, ambiguous for the two-view pose, does not degrade.
  bool refine_join = true;
  /// Scale (pixels) of the refinement's Cauchy loss.
  double join_loss_px = 2.0;
  /// When a unique point is predicted visible in the other model's images.
  VisibilityOptions visibility;
  /// Occlusion: a unique point predicted behind the other model's own
  /// structure is hidden, not missing. The other model's points are binned
  /// per image on cells of this side (pixels); a prediction is hidden if a
  /// point within one cell of it is nearer the camera by more than
  /// occlusion_margin (relative).
  double occlusion_cell_px = 32;
  double occlusion_margin = 0.1;
  /// A pair's inlier is consistent with the joined geometry
  /// (EdgeEvidence::consistent) when its epipolar (Sampson) error on the
  /// refined pose and, where it is a model point, its reprojection error
  /// are within this many times relative_pose.support_error_px. A match
  /// one repetition over on a repeated facade lies tens of pixels off its
  /// model point's projection; at 1 (as tight as the pose's own support)
  /// a fifth of the true matches go too, and a chain of views can lose
  /// the shared matches it registers through (decisions.md, 2026-12-03,
  /// sixth session).
  double inlier_error_factor = 6.0;
  /// Record which unique points were missing (EdgeEvidence::missing), for
  /// studies of the test.
  bool record_missing = false;

  /// Throws hisfm::Error if an option is out of range.
  void Check() const;
};

/// What the test measured on one pair.
struct EdgeEvidence {
  /// False if a model is missing or the pair does not join them.
  bool judged = false;
  /// The hypothesis (index into PairGeometry::hypotheses) that joins best.
  int hypothesis = -1;
  /// Inliers that are points of model i / model j with a positive depth,
  /// and the share of them that agree with the joining scale.
  int join_i = 0;
  int join_j = 0;
  double agreement_i = 0;
  double agreement_j = 0;
  /// Unique points of both models, those predicted visible in the other
  /// model's images, and those of them that landed on a keypoint.
  int num_unique = 0;
  int num_visible = 0;
  int num_found = 0;
  /// The same visible points displaced by a few keypoint radii in each of
  /// four directions, found there: how often a projection lands on a
  /// keypoint by chance, at the places where these points project (summed
  /// over the four displacements; divide by 4 num_visible for a rate).
  int num_found_displaced = 0;
  /// Internal consistency counts of the two models
  /// (LocalModel::num_checked, num_found), summed.
  int models_checked = 0;
  int models_found = 0;
  /// Per inlier of the pair (oriented from i to j, PairGeometry::matches
  /// order): consistent with the joined geometry.
  std::vector<char> consistent;
  int num_consistent = 0;
  /// With EdgeTestOptions::record_missing: each missing unique point as
  /// (its model's ego image, keypoint there, the image it was predicted
  /// in, the predicted pixel).
  struct MissingPoint {
    ImageId source = kInvalidImageId;
    uint32_t keypoint = 0;
    ImageId target = kInvalidImageId;
    Eigen::Vector2d pixel = Eigen::Vector2d::Zero();
  };
  std::vector<MissingPoint> missing;

  /// Unique points predicted visible but not found.
  int num_missing() const { return num_visible - num_found; }
  /// num_missing / num_unique (0 without unique points).
  double MissingFraction() const;
};

/// Tests the pair (i, j) given the ego models of i (model_i.images[0] == i)
/// and j, built without the other image.
EdgeEvidence TestEdge(GeometryCache& cache, const LocalModel& model_i,
                      const LocalModel& model_j, ImageId i, ImageId j,
                      const EdgeTestOptions& options);

}  // namespace hisfm
