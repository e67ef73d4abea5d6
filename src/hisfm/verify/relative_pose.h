// Robust relative pose of a calibrated image pair whose inliers mix true and
// doppelganger matches.
//
// A pair that sees repeated structure from a sideways-moving camera (a
// street of identical facades) carries two or more groups of matches that
// satisfy the same epipolar geometry: the true ones, and matches to a copy
// of the structure one period away, which only the sign and length of the
// baseline tell apart (they triangulate behind a camera, or at the wrong
// depth). COLMAP's stored E is fitted to their union and can be degrees
// off; its cheirality vote may pick the wrong sign. Here the rotation of the
// stored E (its two decompositions) seeds a RANSAC over the translation
// alone: with the rotation known, two correspondences fix the translation
// direction (t . (R x1 x x2) = 0 for each; Hartley & Zisserman, "Multiple
// View Geometry", 2nd ed., Sec. 9.6 and 11.1), and a hypothesis is supported
// by the correspondences within max_error_px of Sampson distance that lie
// in front of both cameras (rays too close to parallel to tell are
// neutral). When the stored E itself is wrong (a doppelganger group won
// COLMAP's RANSAC, or the pair is a mix), poses from eight-point samples
// (Hartley, "In Defense of the Eight-Point Algorithm", PAMI 1997, on
// normalized coordinates, projected to the essential manifold) compete
// with it under the same support count. The best hypothesis of each translation sign is refined on its
// support by non-linear least squares over rotation and unit translation
// (Ceres), and both are returned, best first: a caller with more views can
// choose between them.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "hisfm/util/rigid3d.h"

namespace hisfm {

struct RelativePoseOptions {
  /// RANSAC support threshold: Sampson distance in pixels (normalized
  /// distance times the focal length passed in).
  double max_error_px = 2.0;
  /// Threshold of the support reported after refinement (COLMAP's
  /// two-view max_error is 4; true matches of a good pose lie within 2).
  double support_error_px = 2.0;
  /// Two-correspondence samples per rotation candidate.
  int num_samples = 64;
  /// Eight-correspondence samples (full pose, independent of the prior).
  int num_eight_point_samples = 64;
  /// Refinement rounds (each re-selects the support and re-fits).
  int num_refinements = 2;
  /// Correspondences whose rays meet at less than this angle (degrees) do
  /// not vote on cheirality: they support every hypothesis whose epipolar
  /// geometry they satisfy.
  double min_cheirality_angle_deg = 0.5;
  /// Seed of the sampling (the result is a function of the inputs).
  uint32_t seed = 0;

  /// Throws hisfm::Error if an option is out of range.
  void Check() const;
};

/// One relative pose hypothesis.
struct RelativePoseHypothesis {
  /// Camera 2 from camera 1, unit translation.
  Rigid3d cam2_from_cam1;
  /// Correspondences supporting it (support_error_px, cheirality).
  int num_support = 0;
};

/// Estimates the relative pose from normalized correspondences x1[k] <->
/// x2[k], seeded by the essential matrix `E_prior` (x2^T E x1 = 0).
/// `focal` converts normalized distances to pixels. Returns at most two
/// hypotheses, one per translation sign, best first; none if E_prior is
/// degenerate or there are fewer than 5 correspondences.
std::vector<RelativePoseHypothesis> EstimateRelativePose(
    const Eigen::Matrix3d& E_prior, const std::vector<Eigen::Vector2d>& x1,
    const std::vector<Eigen::Vector2d>& x2, double focal,
    const RelativePoseOptions& options);

/// Whether correspondence (x1, x2) supports the pose: Sampson distance
/// below `max_error` (normalized units) and in front of both cameras, or
/// rays meeting at less than `min_angle_cos` (cosine) when not in front.
bool SupportsPose(const Eigen::Matrix3d& R, const Eigen::Vector3d& t,
                  const Eigen::Matrix3d& E, const Eigen::Vector2d& x1,
                  const Eigen::Vector2d& x2, double max_error,
                  double min_angle_cos);

/// The support of the hypotheses (R, t) and (R, -t) in one pass over the
/// correspondences, each counted as SupportsPose counts it: the two share
/// the Sampson distance and the parallel-ray test, and their depths differ
/// only in sign. Counting stops early once neither count can exceed its
/// bound (at_most_plus for t, at_most_minus for -t); a count that can is
/// exact, one that cannot is at most its bound. -1 bounds count in full.
/// EstimateRelativePose scores its candidates this way, with the best
/// support found so far as the bounds (the same hypotheses win as with
/// full counts, for about half the work).
void CountSupportBothSigns(const Eigen::Matrix3d& R, const Eigen::Vector3d& t,
                           const std::vector<Eigen::Vector2d>& x1,
                           const std::vector<Eigen::Vector2d>& x2,
                           double max_error, double min_angle_cos,
                           int at_most_plus, int at_most_minus, int* plus,
                           int* minus);

/// The essential matrix [t]x R of a relative pose.
Eigen::Matrix3d EssentialOfPose(const Rigid3d& cam2_from_cam1);

}  // namespace hisfm
