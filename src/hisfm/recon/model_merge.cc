#include "hisfm/recon/model_merge.h"

#include <algorithm>
#include <map>
#include <unordered_map>

#include "hisfm/eval/similarity_alignment.h"
#include "hisfm/util/error.h"

namespace hisfm {

void ModelMergeOptions::Check() const {
  HISFM_CHECK_OPTION(min_inliers, min_inliers >= 1, ">= 1");
  HISFM_CHECK_OPTION(min_inlier_ratio,
                     min_inlier_ratio >= 0.0 && min_inlier_ratio <= 1.0,
                     "in [0, 1]");
  HISFM_CHECK_OPTION(max_relative_error, max_relative_error > 0.0, "> 0");
}

size_t ModelMergeResult::NumMerged() const {
  return static_cast<size_t>(std::count_if(
      steps.begin(), steps.end(),
      [](const ModelMergeStep& s) { return s.merged; }));
}

namespace {

// A keypoint of a shared image that observes a point in both models.
struct Correspondence {
  ImageId image = kInvalidImageId;
  Point3DId model_point = kInvalidPoint3DId;
  Point3DId other_point = kInvalidPoint3DId;
};

std::vector<Correspondence> SharedObservations(const Reconstruction& other,
                                               const Reconstruction& model,
                                               size_t* num_common_images) {
  std::vector<Correspondence> out;
  *num_common_images = 0;
  for (const auto& [id, image] : other.images) {
    const auto it = model.images.find(id);
    if (it == model.images.end()) continue;
    ++*num_common_images;
    const std::vector<Point2D>& mine = it->second.points2D;
    const size_t n = std::min(mine.size(), image.points2D.size());
    for (size_t k = 0; k < n; ++k) {
      const Point3DId a = mine[k].point3D_id;
      const Point3DId b = image.points2D[k].point3D_id;
      if (a == kInvalidPoint3DId || b == kInvalidPoint3DId) continue;
      if (!model.points3D.count(a) || !other.points3D.count(b)) continue;
      out.push_back({id, a, b});
    }
  }
  return out;
}

// Adds `other` (its points already mapped by model_from_other) to `model`:
// `joined` maps other's points to the model's points they were found to be.
void AddModel(const Reconstruction& other, const Sim3d& model_from_other,
              const std::unordered_map<Point3DId, Point3DId>& joined,
              Reconstruction* model) {
  for (const auto& [id, camera] : other.cameras) {
    model->cameras.emplace(id, camera);
  }
  Point3DId next_id = 1;
  if (!model->points3D.empty()) next_id = model->points3D.rbegin()->first + 1;
  // Where each of other's points goes.
  std::unordered_map<Point3DId, Point3DId> target = joined;
  for (const auto& [id, point] : other.points3D) {
    if (target.count(id)) continue;
    Point3D moved;
    moved.xyz = model_from_other * point.xyz;
    moved.color = point.color;
    moved.error = point.error;
    model->points3D.emplace(next_id, moved);
    target.emplace(id, next_id++);
  }
  // Images only in `other` are moved; their observations follow.
  for (const auto& [id, image] : other.images) {
    if (model->images.count(id)) continue;
    Image moved = image;
    moved.cam_from_world = model_from_other.TransformPose(image.cam_from_world);
    for (Point2D& p : moved.points2D) p.point3D_id = kInvalidPoint3DId;
    model->images.emplace(id, std::move(moved));
  }
  // Observations: each keypoint that observes a point in `other` observes
  // the point it maps to, unless it already observes one in `model`.
  for (const auto& [id, point] : other.points3D) {
    const Point3DId to = target.at(id);
    Point3D& dst = model->points3D.at(to);
    for (const TrackElement& el : point.track) {
      Image& image = model->images.at(el.image_id);
      if (el.point2D_idx >= image.points2D.size()) continue;
      Point2D& p2 = image.points2D[el.point2D_idx];
      if (p2.point3D_id != kInvalidPoint3DId) continue;
      p2.point3D_id = to;
      dst.track.push_back(el);
    }
  }
  // New points left with fewer than two observations are dropped.
  for (auto it = model->points3D.begin(); it != model->points3D.end();) {
    if (it->second.track.size() >= 2) {
      ++it;
      continue;
    }
    for (const TrackElement& el : it->second.track) {
      model->images.at(el.image_id).points2D[el.point2D_idx].point3D_id =
          kInvalidPoint3DId;
    }
    it = model->points3D.erase(it);
  }
}

}  // namespace

ModelMergeStep MergeInto(const Reconstruction& other,
                         const ModelMergeOptions& options,
                         Reconstruction* model) {
  ModelMergeStep step;
  step.num_images = other.NumRegImages();
  const std::vector<Correspondence> corr =
      SharedObservations(other, *model, &step.num_common_images);
  step.num_correspondences = corr.size();
  if (corr.size() < static_cast<size_t>(options.min_inliers)) return step;
  // One similarity per shared image: its two poses and the median depth
  // ratio of its shared points.
  std::map<ImageId, std::vector<double>> ratios;
  for (const Correspondence& c : corr) {
    const double depth_model =
        (model->images.at(c.image).cam_from_world *
         model->points3D.at(c.model_point).xyz).z();
    const double depth_other = (other.images.at(c.image).cam_from_world *
                                other.points3D.at(c.other_point).xyz).z();
    if (depth_model > 0 && depth_other > 0) {
      ratios[c.image].push_back(depth_model / depth_other);
    }
  }
  std::vector<bool> best_inliers;
  Sim3d best;
  for (auto& [image, r] : ratios) {
    std::nth_element(r.begin(), r.begin() + r.size() / 2, r.end());
    const Rigid3d& cam_from_model = model->images.at(image).cam_from_world;
    const Rigid3d& cam_from_other = other.images.at(image).cam_from_world;
    // x_model = cam_from_model^-1 (s * cam_from_other * x_other).
    Sim3d model_from_other;
    model_from_other.scale = r[r.size() / 2];
    model_from_other.rotation =
        cam_from_model.rotation.inverse() * cam_from_other.rotation;
    model_from_other.translation =
        cam_from_model.rotation.inverse() *
        (model_from_other.scale * cam_from_other.translation -
         cam_from_model.translation);
    std::vector<bool> inliers(corr.size(), false);
    size_t count = 0;
    for (size_t k = 0; k < corr.size(); ++k) {
      const Eigen::Vector3d& x = model->points3D.at(corr[k].model_point).xyz;
      const double depth =
          (model->images.at(corr[k].image).cam_from_world * x).z();
      const Eigen::Vector3d mapped =
          model_from_other * other.points3D.at(corr[k].other_point).xyz;
      if (depth > 0 &&
          (mapped - x).norm() <= options.max_relative_error * depth) {
        inliers[k] = true;
        ++count;
      }
    }
    if (count > step.num_inliers) {
      step.num_inliers = count;
      best_inliers = std::move(inliers);
      best = model_from_other;
    }
  }
  if (step.num_inliers < static_cast<size_t>(options.min_inliers) ||
      step.num_inliers < options.min_inlier_ratio * corr.size()) {
    return step;
  }
  // A point of `other` joins the model's point it corresponds to when they
  // agree (the first such correspondence); the observations of the others
  // on shared keypoints stay with the model's points.
  std::unordered_map<Point3DId, Point3DId> joined;
  for (size_t k = 0; k < corr.size(); ++k) {
    if (best_inliers[k]) joined.emplace(corr[k].other_point, corr[k].model_point);
  }
  AddModel(other, best, joined, model);
  step.merged = true;
  return step;
}

ModelMergeResult MergeModels(const std::vector<Reconstruction>& models,
                             const ModelMergeOptions& options) {
  ThrowUnless(!models.empty(), "MergeModels: no model");
  ModelMergeResult result;
  for (size_t i = 1; i < models.size(); ++i) {
    if (models[i].NumRegImages() > models[result.base].NumRegImages()) {
      result.base = i;
    }
  }
  result.model = models[result.base];
  const bool has_rigs = [&] {
    for (const Reconstruction& m : models) {
      if (m.rigs || m.frames) return true;
    }
    return false;
  }();
  std::vector<size_t> left;
  for (size_t i = 0; i < models.size(); ++i) {
    if (i != result.base) left.push_back(i);
  }
  std::stable_sort(left.begin(), left.end(), [&](size_t a, size_t b) {
    return models[a].NumRegImages() > models[b].NumRegImages();
  });
  // The last attempt on each sub-model not merged.
  std::map<size_t, ModelMergeStep> failed;
  for (size_t i : left) {
    failed[i].model = i;
    failed[i].num_images = models[i].NumRegImages();
  }
  bool progress = !has_rigs;
  while (progress && !left.empty()) {
    progress = false;
    std::vector<size_t> still;
    for (size_t i : left) {
      ModelMergeStep step = MergeInto(models[i], options, &result.model);
      step.model = i;
      if (step.merged) {
        progress = true;
        result.steps.push_back(step);
      } else {
        failed[i] = step;
        still.push_back(i);
      }
    }
    left = std::move(still);
  }
  for (size_t i : left) result.steps.push_back(failed.at(i));
  return result;
}

}  // namespace hisfm
