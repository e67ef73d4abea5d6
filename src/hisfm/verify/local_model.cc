#include "hisfm/verify/local_model.h"

#include <algorithm>
#include <array>
#include <cmath>

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include "hisfm/util/error.h"
#include "hisfm/verify/triangulation.h"

namespace hisfm {
namespace {

// Reprojection error (pixels) of a point given in a camera's frame.
double ReprojectionError(const ImageGeometry& image, const Eigen::Vector3d& Y,
                         uint32_t keypoint) {
  if (!(Y.z() > 0)) return std::numeric_limits<double>::infinity();
  return (Y.hnormalized() - image.normalized[keypoint]).norm() *
         image.camera.MeanFocal();
}

// Checks the two-view points of pair (v, w) of `model` that are not model
// points against its third view u: counts those predicted visible there and
// those that land on a keypoint.
void CheckTwoViewPoints(GeometryCache& cache, const LocalModelOptions& options,
                        int v, int w, int u, LocalModel* model) {
  const double min_angle = options.min_triangulation_angle_deg * M_PI / 180.0;
  const ImageGeometry& iv = cache.Image(model->images[v]);
  const ImageGeometry& iw = cache.Image(model->images[w]);
  const ImageGeometry& iu = cache.Image(model->images[u]);
  const std::shared_ptr<const PairGeometry> vw =
      cache.Pair(model->images[v], model->images[w]);
  std::vector<bool> in_model(iv.normalized.size(), false);
  for (const uint32_t k : model->keypoints[v]) {
    if (k != LocalModel::kNoKeypoint) in_model[k] = true;
  }
  const Rigid3d poses[2] = {model->cam_from_model[v], model->cam_from_model[w]};
  for (const FeatureMatch& m : vw->matches) {
    if (in_model[m.idx1]) continue;
    const Eigen::Vector2d x[2] = {iv.normalized[m.idx1],
                                  iw.normalized[m.idx2]};
    const Eigen::Vector3d X = TriangulateMultiView(poses, x, 2);
    if (!X.allFinite()) continue;
    const Eigen::Vector3d Yv = poses[0] * X;
    const Eigen::Vector3d Yw = poses[1] * X;
    if (ReprojectionError(iv, Yv, m.idx1) > options.max_reprojection_px ||
        ReprojectionError(iw, Yw, m.idx2) > options.max_reprojection_px) {
      continue;
    }
    const Eigen::Vector3d cv = poses[0].Inverse().translation;
    const Eigen::Vector3d cw = poses[1].Inverse().translation;
    if (TriangulationAngle(cv, cw, X) < min_angle) continue;
    Eigen::Vector2d pixel;
    if (!PredictVisible(iu, model->cam_from_model[u], X, cv,
                        options.visibility, &pixel)) {
      continue;
    }
    ++model->num_checked;
    model->num_found += iu.grid.AnyWithin(pixel);
  }
}

// Reprojection residual (pixels) of one observation, for Ceres.
struct ReprojectionResidual {
  ReprojectionResidual(const Eigen::Vector2d& x, double focal)
      : x_(x), focal_(focal) {}

  template <typename T>
  bool operator()(const T* rotation, const T* translation, const T* point,
                  T* residual) const {
    T p[3];
    ceres::AngleAxisRotatePoint(rotation, point, p);
    for (int k = 0; k < 3; ++k) p[k] += translation[k];
    residual[0] = T(focal_) * (p[0] / p[2] - T(x_.x()));
    residual[1] = T(focal_) * (p[1] / p[2] - T(x_.y()));
    return true;
  }

  Eigen::Vector2d x_;
  double focal_;
};

// Cells of the ego image that hold a keypoint of one of the model's points.
int CoverageCells(GeometryCache& cache, const LocalModelOptions& options,
                  const LocalModel& model) {
  const ImageGeometry& ego = cache.Image(model.images[0]);
  std::vector<int64_t> cells;
  cells.reserve(model.points.size());
  for (const uint32_t k : model.keypoints[0]) {
    const Eigen::Vector2d& u = ego.pixels[k];
    cells.push_back(
        static_cast<int64_t>(std::floor(u.x() / options.coverage_cell_px)) *
            1000003 +
        static_cast<int64_t>(std::floor(u.y() / options.coverage_cell_px)));
  }
  std::sort(cells.begin(), cells.end());
  return static_cast<int>(std::unique(cells.begin(), cells.end()) -
                          cells.begin());
}

// Adds the distinctive two-view points of the ego image with view v (see
// LocalModelOptions::distinctive_two_view_points).
void AddDistinctiveTwoViewPoints(GeometryCache& cache,
                                 const LocalModelOptions& options, int v,
                                 LocalModel* model) {
  const ImageGeometry& ie = cache.Image(model->images[0]);
  const ImageGeometry& iv = cache.Image(model->images[v]);
  if (ie.degree.empty() || iv.degree.empty()) return;
  // The median degree of the ego image's matched keypoints.
  std::vector<uint16_t> matched;
  for (const uint16_t d : ie.degree) {
    if (d > 0) matched.push_back(d);
  }
  if (matched.empty()) return;
  std::nth_element(matched.begin(), matched.begin() + matched.size() / 2,
                   matched.end());
  const double max_degree = std::max(
      2.0, options.distinctive_degree_fraction * matched[matched.size() / 2]);
  std::vector<bool> in_model(ie.normalized.size(), false);
  for (const uint32_t k : model->keypoints[0]) in_model[k] = true;
  const std::shared_ptr<const PairGeometry> ev =
      cache.Pair(model->images[0], model->images[v]);
  const Rigid3d poses[2] = {model->cam_from_model[0],
                            model->cam_from_model[v]};
  const Eigen::Vector3d c0 = poses[0].Inverse().translation;
  const Eigen::Vector3d cv = poses[1].Inverse().translation;
  const double min_angle = options.min_triangulation_angle_deg * M_PI / 180.0;
  for (const FeatureMatch& m : ev->matches) {
    if (in_model[m.idx1] || ie.degree[m.idx1] > max_degree ||
        iv.degree[m.idx2] > max_degree) {
      continue;
    }
    const Eigen::Vector2d x[2] = {ie.normalized[m.idx1],
                                  iv.normalized[m.idx2]};
    const Eigen::Vector3d X = TriangulateMultiView(poses, x, 2);
    if (!X.allFinite() ||
        ReprojectionError(ie, poses[0] * X, m.idx1) >
            options.max_reprojection_px ||
        ReprojectionError(iv, poses[1] * X, m.idx2) >
            options.max_reprojection_px ||
        TriangulationAngle(c0, cv, X) < min_angle) {
      continue;
    }
    in_model[m.idx1] = true;
    model->points.push_back(X);
    for (size_t w = 0; w < model->images.size(); ++w) {
      model->keypoints[w].push_back(
          w == 0 ? m.idx1
                 : (static_cast<int>(w) == v ? m.idx2 : LocalModel::kNoKeypoint));
    }
  }
}

}  // namespace

void BundleAdjustModel(GeometryCache& cache, const LocalModelOptions& options,
                       LocalModel* model) {
  const size_t num_views = model->images.size();
  if (num_views < 2 || model->points.empty()) return;
  std::vector<std::array<double, 3>> rotations(num_views), translations(
                                                               num_views);
  for (size_t v = 0; v < num_views; ++v) {
    const Eigen::AngleAxisd aa(model->cam_from_model[v].rotation);
    const Eigen::Vector3d r = aa.angle() * aa.axis();
    const Eigen::Vector3d& t = model->cam_from_model[v].translation;
    rotations[v] = {r.x(), r.y(), r.z()};
    translations[v] = {t.x(), t.y(), t.z()};
  }
  std::vector<std::array<double, 3>> points(model->points.size());
  for (size_t p = 0; p < points.size(); ++p) {
    points[p] = {model->points[p].x(), model->points[p].y(),
                 model->points[p].z()};
  }
  ceres::Problem problem;
  for (size_t v = 0; v < num_views; ++v) {
    const ImageGeometry& image = cache.Image(model->images[v]);
    for (size_t p = 0; p < points.size(); ++p) {
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<ReprojectionResidual, 2, 3, 3, 3>(
              new ReprojectionResidual(
                  image.normalized[model->keypoints[v][p]],
                  image.camera.MeanFocal())),
          new ceres::HuberLoss(1.0), rotations[v].data(),
          translations[v].data(), points[p].data());
    }
  }
  problem.SetParameterBlockConstant(rotations[0].data());
  problem.SetParameterBlockConstant(translations[0].data());
  problem.SetManifold(translations[1].data(), new ceres::SphereManifold<3>());
  ceres::Solver::Options solver;
  solver.linear_solver_type = ceres::DENSE_SCHUR;
  solver.max_num_iterations = 20;
  solver.num_threads = 1;
  solver.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &problem, &summary);
  for (size_t v = 0; v < num_views; ++v) {
    const Eigen::Vector3d r(rotations[v][0], rotations[v][1], rotations[v][2]);
    const double angle = r.norm();
    const Eigen::Quaterniond q =
        angle > 0 ? Eigen::Quaterniond(Eigen::AngleAxisd(angle, r / angle))
                  : Eigen::Quaterniond::Identity();
    model->cam_from_model[v] = Rigid3d(
        q, Eigen::Vector3d(translations[v][0], translations[v][1],
                           translations[v][2]));
  }
  // Keep the points that reproject well in every view.
  LocalModel kept = *model;
  kept.points.clear();
  for (auto& k : kept.keypoints) k.clear();
  for (size_t p = 0; p < points.size(); ++p) {
    const Eigen::Vector3d X(points[p][0], points[p][1], points[p][2]);
    bool ok = X.allFinite();
    for (size_t v = 0; v < num_views && ok; ++v) {
      ok = ReprojectionError(cache.Image(model->images[v]),
                             model->cam_from_model[v] * X,
                             model->keypoints[v][p]) <=
           options.max_reprojection_px;
    }
    if (!ok) continue;
    kept.points.push_back(X);
    for (size_t v = 0; v < num_views; ++v) {
      kept.keypoints[v].push_back(model->keypoints[v][p]);
    }
  }
  *model = std::move(kept);
}

void CheckModelConsistency(GeometryCache& cache,
                           const LocalModelOptions& options,
                           LocalModel* model) {
  model->num_checked = 0;
  model->num_found = 0;
  if (model->images.size() != 3) return;
  CheckTwoViewPoints(cache, options, 0, 1, 2, model);
  CheckTwoViewPoints(cache, options, 0, 2, 1, model);
}

void VisibilityOptions::Check() const {
  HISFM_CHECK_OPTION(max_scale_change, max_scale_change >= 1, ">= 1");
  HISFM_CHECK_OPTION(max_view_angle_deg,
                     max_view_angle_deg > 0 && max_view_angle_deg <= 180,
                     "in (0, 180]");
}

void LocalModelOptions::Check() const {
  HISFM_CHECK_OPTION(num_candidates, num_candidates >= 2, ">= 2");
  HISFM_CHECK_OPTION(max_reprojection_px, max_reprojection_px > 0, "> 0");
  HISFM_CHECK_OPTION(min_points, min_points >= 3, ">= 3");
  visibility.Check();
  HISFM_CHECK_OPTION(coverage_cell_px, coverage_cell_px > 0, "> 0");
  HISFM_CHECK_OPTION(distinctive_degree_fraction,
                     distinctive_degree_fraction > 0, "> 0");
  HISFM_CHECK_OPTION(min_triangulation_angle_deg,
                     min_triangulation_angle_deg >= 0 &&
                     min_triangulation_angle_deg < 90,
                     "in [0, 90)");
}

double LocalModel::Consistency() const {
  return num_checked > 0 ? static_cast<double>(num_found) / num_checked : 1.0;
}

int LocalModel::IndexOf(ImageId image_id) const {
  for (size_t v = 0; v < images.size(); ++v) {
    if (images[v] == image_id) return static_cast<int>(v);
  }
  return -1;
}

bool PredictVisible(const ImageGeometry& target,
                    const Rigid3d& target_from_frame,
                    const Eigen::Vector3d& point,
                    const Eigen::Vector3d& observer_center,
                    const VisibilityOptions& visibility,
                    Eigen::Vector2d* pixel) {
  const Eigen::Vector3d Y = target_from_frame * point;
  if (!(Y.z() > 0)) return false;
  const Eigen::Vector3d target_center = target_from_frame.Inverse().translation;
  const Eigen::Vector3d to_target = target_center - point;
  const Eigen::Vector3d to_observer = observer_center - point;
  const double dt = to_target.norm();
  const double dobs = to_observer.norm();
  if (!(dt > 0) || !(dobs > 0)) return false;
  const double ratio = dt / dobs;
  if (ratio > visibility.max_scale_change ||
      ratio * visibility.max_scale_change < 1) {
    return false;
  }
  if (to_target.dot(to_observer) <
      std::cos(visibility.max_view_angle_deg * M_PI / 180.0) * dt * dobs) {
    return false;
  }
  *pixel = target.camera.NormalizedToPixel(Y.hnormalized());
  return pixel->allFinite() && target.camera.InImage(*pixel);
}

LocalModel BuildTripletModel(GeometryCache& cache, ImageId ego, ImageId a,
                             ImageId c, int hypothesis_a, int hypothesis_c,
                             const LocalModelOptions& options) {
  LocalModel model;
  const std::shared_ptr<const PairGeometry> ea = cache.Pair(ego, a);
  const std::shared_ptr<const PairGeometry> ec = cache.Pair(ego, c);
  if (hypothesis_a >= static_cast<int>(ea->hypotheses.size()) ||
      hypothesis_c >= static_cast<int>(ec->hypotheses.size())) {
    return model;
  }
  const Rigid3d a_from_ego = ea->hypotheses[hypothesis_a].cam2_from_cam1;
  const Rigid3d c_from_ego = ec->hypotheses[hypothesis_c].cam2_from_cam1;
  const ImageGeometry& ie = cache.Image(ego);
  const ImageGeometry& ia = cache.Image(a);
  const ImageGeometry& ic = cache.Image(c);
  const Eigen::Matrix3d Ra = a_from_ego.rotation.toRotationMatrix();
  const Eigen::Matrix3d Rc = c_from_ego.rotation.toRotationMatrix();
  // Keypoints of ego matched in both pairs, and the scale of (ego, c)'s
  // baseline in units of (ego, a)'s from their depths in ego.
  std::vector<uint32_t> shared;
  std::vector<double> ratios;
  for (const FeatureMatch& m : ea->matches) {
    const int32_t kc = ec->from_to[m.idx1];
    if (kc == PairGeometry::kNoMatch) continue;
    shared.push_back(m.idx1);
    double da1 = 0, da2 = 0, dc1 = 0, dc2 = 0;
    if (RayDepths(Ra, a_from_ego.translation, ie.normalized[m.idx1],
                  ia.normalized[m.idx2], &da1, &da2) &&
        RayDepths(Rc, c_from_ego.translation, ie.normalized[m.idx1],
                  ic.normalized[kc], &dc1, &dc2) &&
        da1 > 0 && da2 > 0 && dc1 > 0 && dc2 > 0) {
      ratios.push_back(da1 / dc1);
    }
  }
  if (static_cast<int>(ratios.size()) < options.min_points) return model;
  std::nth_element(ratios.begin(), ratios.begin() + ratios.size() / 2,
                   ratios.end());
  const double scale = ratios[ratios.size() / 2];
  model.images = {ego, a, c};
  model.cam_from_model = {
      Rigid3d(), a_from_ego,
      Rigid3d(c_from_ego.rotation, scale * c_from_ego.translation)};
  model.keypoints.assign(3, {});
  const ImageGeometry* views[3] = {&ie, &ia, &ic};
  for (const uint32_t ke : shared) {
    const uint32_t k[3] = {ke, static_cast<uint32_t>(ea->from_to[ke]),
                           static_cast<uint32_t>(ec->from_to[ke])};
    Eigen::Vector2d x[3];
    for (int v = 0; v < 3; ++v) x[v] = views[v]->normalized[k[v]];
    const Eigen::Vector3d X =
        TriangulateMultiView(model.cam_from_model.data(), x, 3);
    if (!X.allFinite()) continue;
    bool ok = true;
    for (int v = 0; v < 3 && ok; ++v) {
      ok = ReprojectionError(*views[v], model.cam_from_model[v] * X, k[v]) <=
           options.max_reprojection_px;
    }
    if (!ok) continue;
    model.points.push_back(X);
    for (int v = 0; v < 3; ++v) model.keypoints[v].push_back(k[v]);
  }
  if (static_cast<int>(model.points.size()) < options.min_points) {
    return LocalModel();
  }
  CheckModelConsistency(cache, options, &model);
  model.num_cells = CoverageCells(cache, options, model);
  return model;
}

LocalModel BuildEgoModel(GeometryCache& cache, const ViewGraph& graph,
                         ImageId ego, ImageId exclude,
                         const LocalModelOptions& options) {
  return BuildEgoModelFrom(
      cache, ego,
      StrongestNeighbours(graph, ego, options.num_candidates, exclude),
      options);
}

LocalModel BuildEgoModelFrom(GeometryCache& cache, ImageId ego,
                             const std::vector<ImageId>& candidates,
                             const LocalModelOptions& options) {
  LocalModel best;
  for (size_t x = 0; x < candidates.size(); ++x) {
    for (size_t y = x + 1; y < candidates.size(); ++y) {
      const size_t num_a = cache.Pair(ego, candidates[x])->hypotheses.size();
      const size_t num_c = cache.Pair(ego, candidates[y])->hypotheses.size();
      for (size_t ha = 0; ha < num_a; ++ha) {
        for (size_t hc = 0; hc < num_c; ++hc) {
          LocalModel model =
              BuildTripletModel(cache, ego, candidates[x], candidates[y],
                                static_cast<int>(ha), static_cast<int>(hc),
                                options);
          if (model.empty()) continue;
          if (model.num_cells > best.num_cells ||
              (model.num_cells == best.num_cells &&
               model.points.size() > best.points.size())) {
            best = std::move(model);
          }
        }
      }
    }
  }
  if (options.bundle_adjust && !best.empty()) {
    BundleAdjustModel(cache, options, &best);
    if (static_cast<int>(best.points.size()) < options.min_points) {
      return LocalModel();
    }
    CheckModelConsistency(cache, options, &best);
    best.num_cells = CoverageCells(cache, options, best);
  }
  if (options.distinctive_two_view_points && !best.empty()) {
    for (int v = 1; v < static_cast<int>(best.images.size()); ++v) {
      AddDistinctiveTwoViewPoints(cache, options, v, &best);
    }
  }
  return best;
}

std::vector<ImageId> SideNeighbours(const ViewGraph& graph, ImageId ego,
                                    ImageId other, size_t count,
                                    double other_side_ratio) {
  std::vector<ImageId> out;
  if (!graph.HasImage(ego)) return out;
  const size_t index = graph.IndexOf(ego);
  for (const size_t e :
       StrongestEdges(graph, index, graph.IncidentEdges(index).size())) {
    if (out.size() >= count) break;
    const ImageId x = graph.OtherEnd(e, ego);
    if (x == other) continue;
    if (graph.Edges()[e].weight <
        other_side_ratio * graph.Weight(other, x)) {
      continue;
    }
    out.push_back(x);
  }
  return out;
}

}  // namespace hisfm
