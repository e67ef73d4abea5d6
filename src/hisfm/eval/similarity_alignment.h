// Robust similarity alignment of two corresponding point sets (camera
// centres of a model and of a reference, or the 3D points two models share).
//
// Least-squares similarity: S. Umeyama, "Least-Squares Estimation of
// Transformation Parameters Between Two Point Patterns", TPAMI 1991
// (Eigen::umeyama). Robustness: RANSAC (Fischler and Bolles, 1981) over
// minimal samples of three correspondences with MSAC scoring (Torr and
// Zisserman, 2000) and local optimisation by least-squares refits on the
// inliers (LO-RANSAC, Chum, Matas and Kittler, 2003).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "hisfm/util/rigid3d.h"

namespace hisfm {

/// A similarity transform b_from_a: x_b = scale * rotation * x_a + translation.
struct Sim3d {
  double scale = 1.0;
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  /// Applies the transform to a point.
  Eigen::Vector3d operator*(const Eigen::Vector3d& x) const {
    return scale * (rotation * x) + translation;
  }
  /// a_from_b.
  Sim3d Inverse() const;
  /// Moves a camera pose into the new world frame: given cam_from_a,
  /// returns cam_from_b for the same camera, with the camera frame scaled
  /// like the world so that centres map to `*this * centre`.
  Rigid3d TransformPose(const Rigid3d& cam_from_a) const;
  /// The 3x4 matrix [scale * R | t].
  Eigen::Matrix<double, 3, 4> ToMatrix() const;
};

/// Least-squares similarity target_from_source (Umeyama) of at least three
/// correspondences; returns false (leaving *result untouched) if there are
/// fewer or the solution is not finite (e.g. all source points equal).
bool EstimateSimilarity(const std::vector<Eigen::Vector3d>& source,
                        const std::vector<Eigen::Vector3d>& target,
                        Sim3d* result);

/// Diagonal of the axis-aligned bounding box of the points (0 if empty).
double PointSetExtent(const std::vector<Eigen::Vector3d>& points);

struct SimilarityAlignmentOptions {
  /// A correspondence is an inlier when its aligned source point lies within
  /// this distance of its target point, as a fraction of the target points'
  /// extent (PointSetExtent).
  double inlier_threshold = 0.05;
  /// Number of random minimal samples (three correspondences) tried.
  int num_iterations = 1000;
  /// Maximum number of least-squares refits on the inliers after each
  /// sample that improves the best score (local optimisation).
  int num_local_refits = 10;
  /// Seed of the sampler, so that results are reproducible.
  uint32_t random_seed = 1;

  /// Throws hisfm::Error if an option is out of range.
  void Check() const;
};

/// The result of a robust alignment.
struct SimilarityAlignment {
  /// False if there were fewer than three correspondences, the targets have
  /// no extent, or no sample gave a finite similarity.
  bool success = false;
  /// Maps source points onto target points.
  Sim3d target_from_source;
  /// Per correspondence: aligned within the threshold.
  std::vector<bool> inliers;
  size_t num_inliers = 0;
  /// The absolute inlier distance used (inlier_threshold * target extent;
  /// 0 with distances per correspondence).
  double inlier_distance = 0.0;
};

/// Robustly estimates target_from_source from corresponding points
/// (source[i] ~ target[i]); the final transform is the least-squares fit to
/// the inliers of the best sample.
SimilarityAlignment AlignSimilarityRobust(
    const std::vector<Eigen::Vector3d>& source,
    const std::vector<Eigen::Vector3d>& target,
    const SimilarityAlignmentOptions& options);

/// As above, with an inlier distance of its own for each correspondence
/// (finite and > 0; e.g. a fraction of the point's depth, where points
/// far from the cameras are less precise): source[i] is an inlier when it
/// lands within inlier_distances[i] of target[i]. options.inlier_threshold
/// is not used, and the result's inlier_distance is 0. Throws if the sizes
/// differ or a distance is not finite and positive.
SimilarityAlignment AlignSimilarityRobust(
    const std::vector<Eigen::Vector3d>& source,
    const std::vector<Eigen::Vector3d>& target,
    const std::vector<double>& inlier_distances,
    const SimilarityAlignmentOptions& options);

}  // namespace hisfm
