#include "hisfm/verify/local_model.h"

#include <algorithm>
#include <cmath>

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
  const ImageGeometry& iv = cache.Image(model->images[v]);
  const ImageGeometry& iw = cache.Image(model->images[w]);
  const ImageGeometry& iu = cache.Image(model->images[u]);
  const std::shared_ptr<const PairGeometry> vw =
      cache.Pair(model->images[v], model->images[w]);
  std::vector<bool> in_model(iv.normalized.size(), false);
  for (const uint32_t k : model->keypoints[v]) in_model[k] = true;
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
    Eigen::Vector2d pixel;
    if (!PredictVisible(iu, model->cam_from_model[u], X, Yv.z(),
                        options.max_scale_change, &pixel)) {
      continue;
    }
    ++model->num_checked;
    model->num_found += iu.grid.AnyWithin(pixel);
  }
}

}  // namespace

void LocalModelOptions::Check() const {
  HISFM_CHECK_OPTION(num_candidates >= 2);
  HISFM_CHECK_OPTION(max_reprojection_px > 0);
  HISFM_CHECK_OPTION(min_points >= 3);
  HISFM_CHECK_OPTION(min_consistency >= 0 && min_consistency <= 1);
  HISFM_CHECK_OPTION(max_scale_change >= 1);
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
                    const Eigen::Vector3d& point, double observed_depth,
                    double max_scale_change, Eigen::Vector2d* pixel) {
  const Eigen::Vector3d Y = target_from_frame * point;
  if (!(Y.z() > 0) || !(observed_depth > 0)) return false;
  const double ratio = Y.z() / observed_depth;
  if (ratio > max_scale_change || ratio * max_scale_change < 1) return false;
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
  CheckTwoViewPoints(cache, options, 0, 1, 2, &model);
  CheckTwoViewPoints(cache, options, 0, 2, 1, &model);
  return model;
}

LocalModel BuildEgoModel(GeometryCache& cache, const ViewGraph& graph,
                         ImageId ego, ImageId exclude,
                         const LocalModelOptions& options) {
  const std::vector<ImageId> candidates =
      StrongestNeighbours(graph, ego, options.num_candidates, exclude);
  LocalModel best_consistent;
  LocalModel best_weighted;
  double best_weight = -1;
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
          const double weight = model.points.size() * model.Consistency();
          if (model.Consistency() >= options.min_consistency &&
              model.points.size() > best_consistent.points.size()) {
            best_consistent = model;
          }
          if (weight > best_weight) {
            best_weight = weight;
            best_weighted = std::move(model);
          }
        }
      }
    }
  }
  return best_consistent.empty() ? best_weighted : best_consistent;
}

}  // namespace hisfm
