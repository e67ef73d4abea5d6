#include "hisfm/eval/similarity_alignment.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include "hisfm/util/error.h"

namespace hisfm {
namespace {

Eigen::Matrix3Xd ToMatrix(const std::vector<Eigen::Vector3d>& points,
                          const std::vector<size_t>& indices) {
  Eigen::Matrix3Xd m(3, indices.size());
  for (size_t i = 0; i < indices.size(); ++i) m.col(i) = points[indices[i]];
  return m;
}

bool EstimateSimilarityOn(const std::vector<Eigen::Vector3d>& source,
                          const std::vector<Eigen::Vector3d>& target,
                          const std::vector<size_t>& indices, Sim3d* result) {
  if (indices.size() < 3) return false;
  const Eigen::Matrix3Xd src = ToMatrix(source, indices);
  const Eigen::Matrix3Xd dst = ToMatrix(target, indices);
  // Umeyama divides by the source variance: reject coincident sources.
  const Eigen::Vector3d mean = src.rowwise().mean();
  if ((src.colwise() - mean).squaredNorm() <= 0.0) return false;
  const Eigen::Matrix4d m = Eigen::umeyama(src, dst, /*with_scaling=*/true);
  if (!m.allFinite()) return false;
  const Eigen::Matrix3d scaled_rotation = m.topLeftCorner<3, 3>();
  const double scale = std::cbrt(scaled_rotation.determinant());
  if (!(scale > 0.0) || !std::isfinite(scale)) return false;
  Sim3d sim;
  sim.scale = scale;
  sim.rotation = Eigen::Quaterniond(scaled_rotation / scale).normalized();
  sim.translation = m.topRightCorner<3, 1>();
  *result = sim;
  return true;
}

// MSAC score (lower is better) and inlier mask of a candidate: each
// correspondence's squared residual over its squared inlier distance, capped
// at 1.
double Score(const Sim3d& sim, const std::vector<Eigen::Vector3d>& source,
             const std::vector<Eigen::Vector3d>& target,
             const std::vector<double>& distances,
             std::vector<size_t>* inliers) {
  double score = 0.0;
  inliers->clear();
  for (size_t i = 0; i < source.size(); ++i) {
    const double r_sq = (sim * source[i] - target[i]).squaredNorm();
    const double threshold_sq = distances[i] * distances[i];
    if (r_sq < threshold_sq) {
      inliers->push_back(i);
      score += r_sq / threshold_sq;
    } else {
      score += 1.0;
    }
  }
  return score;
}

}  // namespace

Sim3d Sim3d::Inverse() const {
  Sim3d inv;
  inv.scale = 1.0 / scale;
  inv.rotation = rotation.inverse();
  inv.translation = -(inv.scale * (inv.rotation * translation));
  return inv;
}

Rigid3d Sim3d::TransformPose(const Rigid3d& cam_from_a) const {
  // x_cam = R_c x_a + t_c and x_a = R^T (x_b - t) / s; scaling the camera
  // frame by s gives s x_cam = R_c R^T x_b - R_c R^T t + s t_c.
  const Eigen::Quaterniond r = cam_from_a.rotation * rotation.inverse();
  return Rigid3d(r, scale * cam_from_a.translation - r * translation);
}

Eigen::Matrix<double, 3, 4> Sim3d::ToMatrix() const {
  Eigen::Matrix<double, 3, 4> m;
  m.leftCols<3>() = scale * rotation.toRotationMatrix();
  m.col(3) = translation;
  return m;
}

bool EstimateSimilarity(const std::vector<Eigen::Vector3d>& source,
                        const std::vector<Eigen::Vector3d>& target,
                        Sim3d* result) {
  ThrowUnless(source.size() == target.size(),
              "EstimateSimilarity: point sets differ in size");
  std::vector<size_t> all(source.size());
  for (size_t i = 0; i < all.size(); ++i) all[i] = i;
  return EstimateSimilarityOn(source, target, all, result);
}

double PointSetExtent(const std::vector<Eigen::Vector3d>& points) {
  if (points.empty()) return 0.0;
  Eigen::Vector3d lo = points.front(), hi = points.front();
  for (const Eigen::Vector3d& p : points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  return (hi - lo).norm();
}

void SimilarityAlignmentOptions::Check() const {
  HISFM_CHECK_OPTION(inlier_threshold, inlier_threshold > 0.0, "> 0.0");
  HISFM_CHECK_OPTION(num_iterations, num_iterations > 0, "> 0");
  HISFM_CHECK_OPTION(num_local_refits, num_local_refits >= 0, ">= 0");
}

SimilarityAlignment AlignSimilarityRobust(
    const std::vector<Eigen::Vector3d>& source,
    const std::vector<Eigen::Vector3d>& target,
    const SimilarityAlignmentOptions& options) {
  options.Check();
  ThrowUnless(source.size() == target.size(),
              "AlignSimilarityRobust: point sets differ in size");
  const double extent = PointSetExtent(target);
  const double threshold = options.inlier_threshold * extent;
  if (source.size() < 3 || !(extent > 0.0) || !std::isfinite(threshold)) {
    SimilarityAlignment result;
    result.inliers.assign(source.size(), false);
    return result;
  }
  SimilarityAlignment result = AlignSimilarityRobust(
      source, target, std::vector<double>(source.size(), threshold), options);
  result.inlier_distance = threshold;
  return result;
}

SimilarityAlignment AlignSimilarityRobust(
    const std::vector<Eigen::Vector3d>& source,
    const std::vector<Eigen::Vector3d>& target,
    const std::vector<double>& inlier_distances,
    const SimilarityAlignmentOptions& options) {
  options.Check();
  ThrowUnless(source.size() == target.size() &&
                  source.size() == inlier_distances.size(),
              "AlignSimilarityRobust: point sets differ in size");
  ThrowUnless(std::all_of(inlier_distances.begin(), inlier_distances.end(),
                          [](double d) { return std::isfinite(d) && d > 0; }),
              "AlignSimilarityRobust: inlier distances must be finite and > 0");
  SimilarityAlignment result;
  result.inliers.assign(source.size(), false);
  const size_t n = source.size();
  if (n < 3) return result;

  std::mt19937 rng(options.random_seed);
  std::uniform_int_distribution<size_t> pick(0, n - 1);
  double best_score = std::numeric_limits<double>::infinity();
  Sim3d best;
  std::vector<size_t> best_inliers, inliers, sample(3);
  for (int iteration = 0; iteration < options.num_iterations; ++iteration) {
    sample[0] = pick(rng);
    do sample[1] = pick(rng); while (sample[1] == sample[0]);
    do sample[2] = pick(rng);
    while (sample[2] == sample[0] || sample[2] == sample[1]);
    Sim3d candidate;
    if (!EstimateSimilarityOn(source, target, sample, &candidate)) continue;
    double score = Score(candidate, source, target, inlier_distances, &inliers);
    if (score >= best_score) continue;
    // Local optimisation: refit on the inliers while the score improves.
    for (int refit = 0; refit < options.num_local_refits; ++refit) {
      Sim3d refined;
      if (!EstimateSimilarityOn(source, target, inliers, &refined)) break;
      std::vector<size_t> refined_inliers;
      const double refined_score =
          Score(refined, source, target, inlier_distances, &refined_inliers);
      if (refined_score >= score) break;
      candidate = refined;
      score = refined_score;
      inliers.swap(refined_inliers);
    }
    best_score = score;
    best = candidate;
    best_inliers = inliers;
  }
  if (!std::isfinite(best_score)) return result;

  // Final least-squares fit on the inliers, kept if it does not lose any.
  Sim3d final_sim;
  if (EstimateSimilarityOn(source, target, best_inliers, &final_sim)) {
    std::vector<size_t> final_inliers;
    const double final_score =
        Score(final_sim, source, target, inlier_distances, &final_inliers);
    if (final_score <= best_score) {
      best = final_sim;
      best_inliers = final_inliers;
    }
  }
  result.success = true;
  result.target_from_source = best;
  for (const size_t i : best_inliers) result.inliers[i] = true;
  result.num_inliers = best_inliers.size();
  return result;
}

}  // namespace hisfm
