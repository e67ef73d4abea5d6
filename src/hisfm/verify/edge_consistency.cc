#include "hisfm/verify/edge_consistency.h"

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
  HISFM_CHECK_OPTION(depth_tolerance > 0 && depth_tolerance < 1);
  HISFM_CHECK_OPTION(min_join_points >= 1);
  HISFM_CHECK_OPTION(min_unique_points >= 1);
  visibility.Check();
  HISFM_CHECK_OPTION(occlusion_cell_px > 0);
  HISFM_CHECK_OPTION(occlusion_margin >= 0);
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
  // Every hypothesis that joins both models is tested; the one whose
  // predictions the models contradict least wins (a pair mixing true and
  // doppelganger matches carries one hypothesis for each group, and the
  // doppelganger one may join the models as well as the true one).
  double best_rank[2] = {-1, -1};
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
    const double si = join_i.scale;
    const double sj = join_j.scale;
    // Model j's frame (j's camera, its units) to model i's, and back.
    const auto j_to_i = [&](const Eigen::Vector3d& X) {
      return Eigen::Vector3d(si * (R.transpose() * (X / sj - t)));
    };
    const auto i_to_j = [&](const Eigen::Vector3d& X) {
      return Eigen::Vector3d(sj * (R * (X / si) + t));
    };
    EdgeEvidence candidate;
    CountPredictions(cache, model_j, model_i, j_to_i, options, &candidate);
    CountPredictions(cache, model_i, model_j, i_to_j, options, &candidate);
    // Rank: hypotheses whose test speaks first, by fewer contradictions;
    // then by how well they join.
    const bool speaks = candidate.num_unique >= options.min_unique_points;
    const double join = join_i.agreement * join_i.num_points +
                        join_j.agreement * join_j.num_points;
    const double rank[2] = {speaks ? 2.0 - candidate.MissingFraction() : 0.0,
                            join};
    if (rank[0] > best_rank[0] ||
        (rank[0] == best_rank[0] && rank[1] > best_rank[1])) {
      best_rank[0] = rank[0];
      best_rank[1] = rank[1];
      candidate.hypothesis = static_cast<int>(h);
      evidence = std::move(candidate);
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
  const Rigid3d& j_from_i = pair->hypotheses[evidence.hypothesis].cam2_from_cam1;
  const Eigen::Matrix3d R = j_from_i.rotation.toRotationMatrix();
  const Eigen::Vector3d& t = j_from_i.translation;
  const double si = best_i.scale;
  const double sj = best_j.scale;
  // The pair's inliers that agree with the joined geometry.
  const double focal = 0.5 * (ii.camera.MeanFocal() + ij.camera.MeanFocal());
  const double max_error =
      cache.options().relative_pose.support_error_px / focal;
  const double angle_cos = std::cos(
      cache.options().relative_pose.min_cheirality_angle_deg * M_PI / 180.0);
  const Eigen::Matrix3d E = EssentialOfPose(j_from_i);
  evidence.consistent.assign(pair->matches.size(), 0);
  for (size_t k = 0; k < pair->matches.size(); ++k) {
    const FeatureMatch& m = pair->matches[k];
    const Eigen::Vector2d& x1 = ii.normalized[m.idx1];
    const Eigen::Vector2d& x2 = ij.normalized[m.idx2];
    if (!SupportsPose(R, t, E, x1, x2, max_error, angle_cos)) continue;
    double d1 = 0, d2 = 0;
    const bool depths = RayDepths(R, t, x1, x2, &d1, &d2) && d1 > 0 && d2 > 0;
    const int pi = point_i[m.idx1];
    const int pj = point_j[m.idx2];
    if (depths && pi >= 0 &&
        std::abs(d1 * si / model_i.points[pi].z() - 1) >=
            options.depth_tolerance) {
      continue;
    }
    if (depths && pj >= 0 &&
        std::abs(d2 * sj / model_j.points[pj].z() - 1) >=
            options.depth_tolerance) {
      continue;
    }
    evidence.consistent[k] = 1;
    ++evidence.num_consistent;
  }
  return evidence;
}

}  // namespace hisfm
