#include "hisfm/verify/edge_consistency.h"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "hisfm/util/error.h"
#include "hisfm/verify/triangulation.h"

namespace hisfm {
namespace {

// Scale of a model against the pair's unit baseline: the median ratio of
// model depth to pair depth over the model points the pair matches, and the
// share of them within `tolerance` of it.
struct Join {
  int num_points = 0;
  double scale = 0;
  double agreement = 0;
};

Join JoinScale(std::vector<double> ratios, double tolerance) {
  Join join;
  join.num_points = static_cast<int>(ratios.size());
  if (ratios.empty()) return join;
  std::nth_element(ratios.begin(), ratios.begin() + ratios.size() / 2,
                   ratios.end());
  join.scale = ratios[ratios.size() / 2];
  int agree = 0;
  for (const double r : ratios) {
    agree += std::abs(r / join.scale - 1) < tolerance;
  }
  join.agreement = static_cast<double>(agree) / ratios.size();
  return join;
}

// Points of `x` none of whose keypoints is matched to an image of `y`.
std::vector<bool> UniquePoints(GeometryCache& cache, const LocalModel& x,
                               const LocalModel& y) {
  std::vector<bool> unique(x.points.size(), true);
  for (size_t v = 0; v < x.images.size(); ++v) {
    for (const ImageId other : y.images) {
      if (other == x.images[v] || !cache.HasPair(x.images[v], other)) continue;
      const std::shared_ptr<const PairGeometry> pair =
          cache.Pair(x.images[v], other);
      for (size_t p = 0; p < x.points.size(); ++p) {
        const uint32_t k = x.keypoints[v][p];
        if (k != LocalModel::kNoKeypoint &&
            pair->from_to[k] != PairGeometry::kNoMatch) {
          unique[p] = false;
        }
      }
    }
  }
  return unique;
}

// Nearest depth of a model's points per image cell, for one of its views.
class DepthGrid {
 public:
  DepthGrid(const ImageGeometry& image, const LocalModel& model, int view,
            double cell_px)
      : cell_(cell_px),
        cols_(static_cast<int>(std::ceil(image.camera.width() / cell_px)) + 1),
        rows_(static_cast<int>(std::ceil(image.camera.height() / cell_px)) +
              1),
        depth_(static_cast<size_t>(cols_) * rows_,
               std::numeric_limits<double>::infinity()) {
    for (size_t p = 0; p < model.points.size(); ++p) {
      const uint32_t k = model.keypoints[view][p];
      if (k == LocalModel::kNoKeypoint) continue;
      const Eigen::Vector3d Y = model.cam_from_model[view] * model.points[p];
      if (!(Y.z() > 0)) continue;
      const Eigen::Vector2d& u = image.pixels[k];
      const int cx = Cell(u.x(), cols_), cy = Cell(u.y(), rows_);
      double& d = depth_[static_cast<size_t>(cy) * cols_ + cx];
      d = std::min(d, Y.z());
    }
  }
  // Smallest depth within one cell of `pixel`.
  double NearestAround(const Eigen::Vector2d& pixel) const {
    const int cx = Cell(pixel.x(), cols_), cy = Cell(pixel.y(), rows_);
    double d = std::numeric_limits<double>::infinity();
    for (int y = std::max(0, cy - 1); y <= std::min(rows_ - 1, cy + 1); ++y) {
      for (int x = std::max(0, cx - 1); x <= std::min(cols_ - 1, cx + 1); ++x) {
        d = std::min(d, depth_[static_cast<size_t>(y) * cols_ + x]);
      }
    }
    return d;
  }

 private:
  int Cell(double v, int n) const {
    return std::clamp(static_cast<int>(std::floor(v / cell_)), 0, n - 1);
  }
  double cell_;
  int cols_, rows_;
  std::vector<double> depth_;
};

// Camera j's pose in model i's frame (x_j = R X_i + t, model i's units) and
// the scale that takes model j's units to model i's.
struct JoinedPose {
  Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  Eigen::Vector3d t = Eigen::Vector3d::Zero();
  double scale = 1;
};

// A model point seen in the other image of the pair: a point of model i
// observed in j, or (in_i) a point of model j observed in i.
struct JoinObservation {
  Eigen::Vector3d point;
  Eigen::Vector2d x;
  double focal = 1;
  bool in_i = false;
};

// Reprojection error (pixels) of a point given in a camera's frame.
double ReprojectionPixels(const Eigen::Vector3d& Y, const Eigen::Vector2d& x,
                          double focal) {
  if (!(Y.z() > 0)) return std::numeric_limits<double>::infinity();
  return (Y.hnormalized() - x).norm() * focal;
}

// Reprojection residual of a JoinObservation under (rotation, t, log scale).
struct JoinResidual {
  explicit JoinResidual(const JoinObservation& o) : o_(o) {}

  template <typename T>
  bool operator()(const T* rotation, const T* t, const T* log_scale,
                  T* residual) const {
    T p[3];
    if (!o_.in_i) {
      const T X[3] = {T(o_.point.x()), T(o_.point.y()), T(o_.point.z())};
      ceres::AngleAxisRotatePoint(rotation, X, p);
      for (int k = 0; k < 3; ++k) p[k] += t[k];
    } else {
      // Model j's point in j's frame, model i's units, then into i's frame.
      const T s = exp(log_scale[0]);
      const T Y[3] = {s * T(o_.point.x()) - t[0], s * T(o_.point.y()) - t[1],
                      s * T(o_.point.z()) - t[2]};
      const T inverse[3] = {-rotation[0], -rotation[1], -rotation[2]};
      ceres::AngleAxisRotatePoint(inverse, Y, p);
    }
    residual[0] = T(o_.focal) * (p[0] / p[2] - T(o_.x.x()));
    residual[1] = T(o_.focal) * (p[1] / p[2] - T(o_.x.y()));
    return true;
  }

  JoinObservation o_;
};

// Refines the join on the observations by robust least squares.
void RefineJoin(const std::vector<JoinObservation>& observations,
                const EdgeTestOptions& options, JoinedPose* join) {
  if (observations.size() < 6) return;
  const Eigen::AngleAxisd aa(join->R);
  double rotation[3] = {aa.angle() * aa.axis().x(), aa.angle() * aa.axis().y(),
                        aa.angle() * aa.axis().z()};
  double t[3] = {join->t.x(), join->t.y(), join->t.z()};
  double log_scale = std::log(join->scale);
  ceres::Problem problem;
  for (const JoinObservation& o : observations) {
    problem.AddResidualBlock(
        new ceres::AutoDiffCostFunction<JoinResidual, 2, 3, 3, 1>(
            new JoinResidual(o)),
        new ceres::CauchyLoss(options.join_loss_px), rotation, t, &log_scale);
  }
  ceres::Solver::Options solver;
  solver.linear_solver_type = ceres::DENSE_QR;
  solver.max_num_iterations = 25;
  solver.num_threads = 1;
  solver.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &problem, &summary);
  const Eigen::Vector3d r(rotation[0], rotation[1], rotation[2]);
  const Eigen::Vector3d tr(t[0], t[1], t[2]);
  if (!r.allFinite() || !tr.allFinite() || !std::isfinite(log_scale) ||
      tr.norm() < 1e-12) {
    return;
  }
  const double angle = r.norm();
  join->R = angle > 0 ? Eigen::AngleAxisd(angle, r / angle).toRotationMatrix()
                      : Eigen::Matrix3d::Identity();
  join->t = tr;
  join->scale = std::exp(log_scale);
}

// Counts the unique points of `source` (mapped into `target`'s frame by
// `to_target`, depths scaled by `depth_scale`) predicted visible in
// `target`'s images and found there.
template <typename Map>
void CountPredictions(GeometryCache& cache, const LocalModel& source,
                      const LocalModel& target, const Map& to_target,
                      const EdgeTestOptions& options,
                      EdgeEvidence* evidence) {
  const std::vector<bool> unique = UniquePoints(cache, source, target);
  std::vector<DepthGrid> depths;
  for (size_t v = 0; v < target.images.size(); ++v) {
    depths.emplace_back(cache.Image(target.images[v]), target,
                        static_cast<int>(v), options.occlusion_cell_px);
  }
  // The source's ego camera saw every one of its points.
  const Eigen::Vector3d observer =
      to_target(source.cam_from_model[0].Inverse().translation);
  for (size_t p = 0; p < source.points.size(); ++p) {
    if (!unique[p]) continue;
    ++evidence->num_unique;
    const Eigen::Vector3d X = to_target(source.points[p]);
    bool visible = false;
    bool found = false;
    int displaced = 0;
    EdgeEvidence::MissingPoint first;
    for (size_t v = 0; v < target.images.size() && !found; ++v) {
      const ImageGeometry& image = cache.Image(target.images[v]);
      Eigen::Vector2d pixel;
      if (!PredictVisible(image, target.cam_from_model[v], X, observer,
                          options.visibility, &pixel)) {
        continue;
      }
      const double depth = (target.cam_from_model[v] * X).z();
      if (depth > depths[v].NearestAround(pixel) *
                      (1 + options.occlusion_margin)) {
        continue;  // Hidden behind the target's own structure.
      }
      if (!visible) {
        first = {source.images[0], source.keypoints[0][p], target.images[v],
                 pixel};
        // Chance control at the first view that should see the point.
        const double d = 4 * cache.options().keypoint_radius_px;
        for (const Eigen::Vector2d& offset :
             {Eigen::Vector2d(d, 0), Eigen::Vector2d(-d, 0),
              Eigen::Vector2d(0, d), Eigen::Vector2d(0, -d)}) {
          displaced += image.grid.AnyWithin(pixel + offset);
        }
      }
      visible = true;
      found = image.grid.AnyWithin(pixel);
    }
    evidence->num_visible += visible;
    evidence->num_found += found;
    if (options.record_missing && visible && !found) {
      evidence->missing.push_back(first);
    }
    evidence->num_found_displaced += displaced;
  }
}

}  // namespace

void EdgeTestOptions::Check() const {
  HISFM_CHECK_OPTION(depth_tolerance,
                     depth_tolerance > 0 && depth_tolerance < 1, "in (0, 1)");
  HISFM_CHECK_OPTION(min_join_points, min_join_points >= 1, ">= 1");
  HISFM_CHECK_OPTION(join_loss_px, join_loss_px > 0, "> 0");
  visibility.Check();
  HISFM_CHECK_OPTION(occlusion_cell_px, occlusion_cell_px > 0, "> 0");
  HISFM_CHECK_OPTION(occlusion_margin, occlusion_margin >= 0, ">= 0");
  HISFM_CHECK_OPTION(inlier_error_factor, inlier_error_factor >= 1, ">= 1");
}

double EdgeEvidence::MissingFraction() const {
  return num_unique > 0 ? static_cast<double>(num_missing()) / num_unique
                        : 0.0;
}

EdgeEvidence TestEdge(GeometryCache& cache, const LocalModel& model_i,
                      const LocalModel& model_j, ImageId i, ImageId j,
                      const EdgeTestOptions& options) {
  EdgeEvidence evidence;
  if (model_i.empty() || model_j.empty() || model_i.images[0] != i ||
      model_j.images[0] != j) {
    return evidence;
  }
  const std::shared_ptr<const PairGeometry> pair = cache.Pair(i, j);
  const ImageGeometry& ii = cache.Image(i);
  const ImageGeometry& ij = cache.Image(j);
  // Model points by ego keypoint.
  std::vector<int> point_i(ii.normalized.size(), -1);
  std::vector<int> point_j(ij.normalized.size(), -1);
  for (size_t p = 0; p < model_i.points.size(); ++p) {
    point_i[model_i.keypoints[0][p]] = static_cast<int>(p);
  }
  for (size_t p = 0; p < model_j.points.size(); ++p) {
    point_j[model_j.keypoints[0][p]] = static_cast<int>(p);
  }
  // The hypothesis that joins both models best is tested.
  double best_join = -1;
  Join best_i, best_j;
  for (size_t h = 0; h < pair->hypotheses.size(); ++h) {
    const Rigid3d& j_from_i = pair->hypotheses[h].cam2_from_cam1;
    const Eigen::Matrix3d R = j_from_i.rotation.toRotationMatrix();
    const Eigen::Vector3d& t = j_from_i.translation;
    std::vector<double> ratios_i, ratios_j;
    for (const FeatureMatch& m : pair->matches) {
      const int pi = point_i[m.idx1];
      const int pj = point_j[m.idx2];
      if (pi < 0 && pj < 0) continue;
      double d1 = 0, d2 = 0;
      if (!RayDepths(R, t, ii.normalized[m.idx1], ij.normalized[m.idx2], &d1,
                     &d2) ||
          d1 <= 0 || d2 <= 0) {
        continue;
      }
      if (pi >= 0 && model_i.points[pi].z() > 0) {
        ratios_i.push_back(model_i.points[pi].z() / d1);
      }
      if (pj >= 0 && model_j.points[pj].z() > 0) {
        ratios_j.push_back(model_j.points[pj].z() / d2);
      }
    }
    const Join join_i = JoinScale(ratios_i, options.depth_tolerance);
    const Join join_j = JoinScale(ratios_j, options.depth_tolerance);
    if (join_i.num_points < options.min_join_points ||
        join_j.num_points < options.min_join_points) {
      continue;
    }
    const double join = join_i.agreement * join_i.num_points +
                        join_j.agreement * join_j.num_points;
    if (join > best_join) {
      best_join = join;
      evidence.hypothesis = static_cast<int>(h);
      best_i = join_i;
      best_j = join_j;
    }
  }
  if (evidence.hypothesis < 0) return evidence;
  evidence.judged = true;
  evidence.models_checked = model_i.num_checked + model_j.num_checked;
  evidence.models_found = model_i.num_found + model_j.num_found;
  evidence.join_i = best_i.num_points;
  evidence.join_j = best_j.num_points;
  evidence.agreement_i = best_i.agreement;
  evidence.agreement_j = best_j.agreement;
  const Rigid3d& hypothesis =
      pair->hypotheses[evidence.hypothesis].cam2_from_cam1;
  // The join: camera j in model i's frame and model j's scale in model i's
  // units, refined on the pair's inliers that are model points.
  JoinedPose join;
  join.R = hypothesis.rotation.toRotationMatrix();
  join.t = best_i.scale * hypothesis.translation;
  join.scale = best_i.scale / best_j.scale;
  std::vector<JoinObservation> observations;
  for (const FeatureMatch& m : pair->matches) {
    const int pi = point_i[m.idx1];
    const int pj = point_j[m.idx2];
    if (pi >= 0) {
      observations.push_back({model_i.points[pi], ij.normalized[m.idx2],
                              ij.camera.MeanFocal(), false});
    }
    if (pj >= 0) {
      observations.push_back({model_j.points[pj], ii.normalized[m.idx1],
                              ii.camera.MeanFocal(), true});
    }
  }
  if (options.refine_join) RefineJoin(observations, options, &join);
  const auto j_to_i = [&](const Eigen::Vector3d& X) {
    return Eigen::Vector3d(join.R.transpose() * (join.scale * X - join.t));
  };
  const auto i_to_j = [&](const Eigen::Vector3d& X) {
    return Eigen::Vector3d((join.R * X + join.t) / join.scale);
  };
  CountPredictions(cache, model_j, model_i, j_to_i, options, &evidence);
  CountPredictions(cache, model_i, model_j, i_to_j, options, &evidence);
  // The pair's inliers that agree with the joined geometry: on the epipolar
  // geometry of the refined pose, and where they are model points, on the
  // model point's reprojection.
  const double max_error_px = options.inlier_error_factor *
                              cache.options().relative_pose.support_error_px;
  const double focal = 0.5 * (ii.camera.MeanFocal() + ij.camera.MeanFocal());
  const double angle_cos = std::cos(
      cache.options().relative_pose.min_cheirality_angle_deg * M_PI / 180.0);
  const Eigen::Vector3d unit_t = join.t.normalized();
  const Eigen::Matrix3d E =
      EssentialOfPose(Rigid3d(Eigen::Quaterniond(join.R), unit_t));
  evidence.consistent.assign(pair->matches.size(), 0);
  for (size_t k = 0; k < pair->matches.size(); ++k) {
    const FeatureMatch& m = pair->matches[k];
    const Eigen::Vector2d& x1 = ii.normalized[m.idx1];
    const Eigen::Vector2d& x2 = ij.normalized[m.idx2];
    if (!SupportsPose(join.R, unit_t, E, x1, x2, max_error_px / focal,
                      angle_cos)) {
      continue;
    }
    const int pi = point_i[m.idx1];
    const int pj = point_j[m.idx2];
    if (pi >= 0 && ReprojectionPixels(join.R * model_i.points[pi] + join.t,
                                      x2, ij.camera.MeanFocal()) >
                       max_error_px) {
      continue;
    }
    if (pj >= 0 && ReprojectionPixels(j_to_i(model_j.points[pj]), x1,
                                      ii.camera.MeanFocal()) > max_error_px) {
      continue;
    }
    evidence.consistent[k] = 1;
    ++evidence.num_consistent;
  }
  return evidence;
}

}  // namespace hisfm
