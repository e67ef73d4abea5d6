#include "hisfm/recon/model_merge.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <map>
#include <optional>
#include <set>
#include <unordered_map>

#include "hisfm/eval/similarity_alignment.h"
#include "hisfm/util/error.h"

namespace hisfm {

void ModelMergeOptions::Check() const {
  HISFM_CHECK_OPTION(min_inliers, min_inliers >= 1, ">= 1");
  HISFM_CHECK_OPTION(min_inlier_ratio,
                     min_inlier_ratio >= 0.0 && min_inlier_ratio <= 1.0,
                     "in [0, 1]");
  HISFM_CHECK_OPTION(max_relative_error,
                     std::isfinite(max_relative_error) && max_relative_error > 0,
                     "finite and > 0");
  HISFM_CHECK_OPTION(num_refits, num_refits >= 0, ">= 0");
}

size_t ModelMergeResult::NumMerged() const {
  return static_cast<size_t>(std::count_if(
      steps.begin(), steps.end(),
      [](const ModelMergeStep& s) { return s.merged; }));
}

namespace {

// A keypoint of a shared image that observes a point in both models, with
// the two points and their depths in that image.
struct Correspondence {
  ImageId image = kInvalidImageId;
  Point3DId model_point = kInvalidPoint3DId;
  Point3DId other_point = kInvalidPoint3DId;
  Eigen::Vector3d model_xyz;
  Eigen::Vector3d other_xyz;
  double model_depth = 0;
  double other_depth = 0;
};

// The correspondence of keypoint `k_model` of `model_image` (image
// `model_id` of `model`) and keypoint `k_other` of `other_image` (of
// `other`), if both observe a 3D point; its depths are in each image.
std::optional<Correspondence> Correspond(const Reconstruction& model,
                                         ImageId model_id,
                                         const Image& model_image,
                                         size_t k_model,
                                         const Reconstruction& other,
                                         const Image& other_image,
                                         size_t k_other) {
  if (k_model >= model_image.points2D.size() ||
      k_other >= other_image.points2D.size()) {
    return std::nullopt;
  }
  const auto a = model.points3D.find(model_image.points2D[k_model].point3D_id);
  const auto b = other.points3D.find(other_image.points2D[k_other].point3D_id);
  if (a == model.points3D.end() || b == other.points3D.end()) {
    return std::nullopt;
  }
  Correspondence c;
  c.image = model_id;
  c.model_point = a->first;
  c.other_point = b->first;
  c.model_xyz = a->second.xyz;
  c.other_xyz = b->second.xyz;
  c.model_depth = (model_image.cam_from_world * c.model_xyz).z();
  c.other_depth = (other_image.cam_from_world * c.other_xyz).z();
  return c;
}

// The shared points of the images registered in both models (with as many
// keypoints in both; other images are not shared).
std::vector<Correspondence> SharedObservations(const Reconstruction& other,
                                               const Reconstruction& model,
                                               size_t* num_common_images) {
  std::vector<Correspondence> out;
  *num_common_images = 0;
  for (const auto& [id, image] : other.images) {
    const auto it = model.images.find(id);
    if (it == model.images.end()) continue;
    const std::vector<Point2D>& mine = it->second.points2D;
    if (mine.size() != image.points2D.size()) continue;
    ++*num_common_images;
    for (size_t k = 0; k < mine.size(); ++k) {
      const std::optional<Correspondence> c =
          Correspond(model, id, it->second, k, other, image, k);
      if (c) out.push_back(*c);
    }
  }
  return out;
}

// True if every rig has one sensor (COLMAP 3.12 writes one such rig per
// camera for images without a rig): a frame is then one image, and its
// rig_from_world is the image's cam_from_world.
bool HasOnlySingleSensorRigs(const Reconstruction& model) {
  if (!model.rigs) return true;
  for (const Rig& rig : *model.rigs) {
    if (!rig.sensors.empty()) return false;
  }
  return true;
}

// True if the two models can be merged as far as rigs go: neither has rigs
// and frames, or both have, of single sensors only.
bool RigsMergeable(const Reconstruction& a, const Reconstruction& b) {
  const bool rigs_a = a.rigs || a.frames;
  const bool rigs_b = b.rigs || b.frames;
  if (rigs_a != rigs_b) return false;
  return HasOnlySingleSensorRigs(a) && HasOnlySingleSensorRigs(b);
}

// Adds the rigs and frames of `other` that `model` lacks, for the images
// `added` (moved by model_from_other).
void AddRigsAndFrames(const Reconstruction& other, const Sim3d& model_from_other,
                      const std::vector<ImageId>& added,
                      Reconstruction* model) {
  if (!other.rigs || !other.frames || !model->rigs || !model->frames) return;
  for (const Rig& rig : *other.rigs) {
    const bool known = std::any_of(
        model->rigs->begin(), model->rigs->end(),
        [&](const Rig& r) { return r.rig_id == rig.rig_id; });
    if (!known) model->rigs->push_back(rig);
  }
  for (const Frame& frame : *other.frames) {
    const bool wanted = std::any_of(
        frame.data.begin(), frame.data.end(), [&](const FrameData& d) {
          return d.sensor.type == SensorType::kCamera &&
                 std::find(added.begin(), added.end(), d.data_id) != added.end();
        });
    const bool known = std::any_of(
        model->frames->begin(), model->frames->end(),
        [&](const Frame& f) { return f.frame_id == frame.frame_id; });
    if (!wanted || known) continue;
    Frame moved = frame;
    if (moved.rig_from_world) {
      moved.rig_from_world = model_from_other.TransformPose(*moved.rig_from_world);
    }
    model->frames->push_back(moved);
  }
}

// Erases the point `it` points to from `model`, clearing the references of
// the images its track holds; returns the iterator past it.
std::map<Point3DId, Point3D>::iterator ErasePoint(
    std::map<Point3DId, Point3D>::iterator it, Reconstruction* model) {
  for (const TrackElement& el : it->second.track) {
    model->images.at(el.image_id).points2D.at(el.point2D_idx).point3D_id =
        kInvalidPoint3DId;
  }
  return model->points3D.erase(it);
}

// Adds `other` (mapped by model_from_other) to `model`: `joined` maps
// other's points to the model's points they were found to be.
void AddModel(const Reconstruction& other, const Sim3d& model_from_other,
              const std::unordered_map<Point3DId, Point3DId>& joined,
              Reconstruction* model) {
  for (const auto& [id, camera] : other.cameras) {
    model->cameras.emplace(id, camera);
  }
  Point3DId next_id = 1;
  if (!model->points3D.empty()) next_id = model->points3D.rbegin()->first + 1;
  // Where each of other's points goes; the new ones, to drop if they end
  // with fewer than two observations.
  std::unordered_map<Point3DId, Point3DId> target = joined;
  std::vector<Point3DId> created;
  for (const auto& [id, point] : other.points3D) {
    if (target.count(id)) continue;
    Point3D moved;
    moved.xyz = model_from_other * point.xyz;
    moved.color = point.color;
    moved.error = point.error;
    model->points3D.emplace(next_id, moved);
    created.push_back(next_id);
    target.emplace(id, next_id++);
  }
  // Images only in `other` are moved; their observations follow.
  std::vector<ImageId> added;
  for (const auto& [id, image] : other.images) {
    if (model->images.count(id)) continue;
    Image moved = image;
    moved.cam_from_world = model_from_other.TransformPose(image.cam_from_world);
    for (Point2D& p : moved.points2D) p.point3D_id = kInvalidPoint3DId;
    model->images.emplace(id, std::move(moved));
    added.push_back(id);
  }
  AddRigsAndFrames(other, model_from_other, added, model);
  // Observations: each keypoint that observes a point in `other` observes
  // the point it maps to, unless it already observes one in `model`.
  for (const auto& [id, point] : other.points3D) {
    const Point3DId to = target.at(id);
    Point3D& dst = model->points3D.at(to);
    for (const TrackElement& el : point.track) {
      const auto image = model->images.find(el.image_id);
      if (image == model->images.end() ||
          el.point2D_idx >= image->second.points2D.size()) {
        continue;
      }
      Point2D& p2 = image->second.points2D[el.point2D_idx];
      if (p2.point3D_id != kInvalidPoint3DId) continue;
      p2.point3D_id = to;
      dst.track.push_back(el);
    }
  }
  for (const Point3DId id : created) {
    const auto it = model->points3D.find(id);
    if (it->second.track.size() < 2) ErasePoint(it, model);
  }
}

// If enough of `corr` agree with `model_from_other` (`inliers`; counts in
// `step`), adds `other` to `model`, each agreeing point of `other` joined
// into its model point (the first correspondence of each, and each model
// point taken once), and marks the step merged.
void JoinIfAgreed(const Reconstruction& other,
                  const std::vector<Correspondence>& corr,
                  const std::vector<bool>& inliers,
                  const Sim3d& model_from_other,
                  const ModelMergeOptions& options, ModelMergeStep* step,
                  Reconstruction* model) {
  if (step->num_inliers < static_cast<size_t>(options.min_inliers) ||
      step->num_inliers < options.min_inlier_ratio * corr.size()) {
    return;
  }
  // The observations of the others on shared keypoints stay with the
  // model's points.
  std::unordered_map<Point3DId, Point3DId> joined;
  std::set<Point3DId> taken;
  for (size_t k = 0; k < corr.size(); ++k) {
    if (!inliers[k] || joined.count(corr[k].other_point) ||
        !taken.insert(corr[k].model_point).second) {
      continue;
    }
    joined.emplace(corr[k].other_point, corr[k].model_point);
  }
  AddModel(other, model_from_other, joined, model);
  step->merged = true;
}

// The correspondences of `pairs` between an image of `model` and one of
// `other`: each inlier match whose keypoints observe a 3D point in both
// models, in front of the model's image (depth there > 0), once per pair of
// points. `num_pairs` counts the pairs that gave any.
std::vector<Correspondence> MatchedObservations(
    const Reconstruction& other, const Reconstruction& model,
    const std::vector<PairMatches>& pairs, size_t* num_pairs) {
  std::vector<Correspondence> out;
  std::set<std::pair<Point3DId, Point3DId>> seen;
  *num_pairs = 0;
  for (const PairMatches& pm : pairs) {
    ImageId model_id = pm.pair.image_id1, other_id = pm.pair.image_id2;
    bool swapped = false;
    if (!model.images.count(model_id) || !other.images.count(other_id)) {
      std::swap(model_id, other_id);
      swapped = true;
    }
    const auto model_image = model.images.find(model_id);
    const auto other_image = other.images.find(other_id);
    if (model_image == model.images.end() ||
        other_image == other.images.end()) {
      continue;
    }
    const size_t before = out.size();
    for (const FeatureMatch& m : pm.matches) {
      const size_t k_model = swapped ? m.idx2 : m.idx1;
      const size_t k_other = swapped ? m.idx1 : m.idx2;
      const std::optional<Correspondence> c =
          Correspond(model, model_id, model_image->second, k_model, other,
                     other_image->second, k_other);
      if (c && c->model_depth > 0 &&
          seen.insert({c->model_point, c->other_point}).second) {
        out.push_back(*c);
      }
    }
    if (out.size() > before) ++*num_pairs;
  }
  return out;
}

// A step's counts before any correspondence: `other`'s images, and whether
// rigs refuse the merge (RigsMergeable).
ModelMergeStep FirstCounts(const Reconstruction& other,
                           const Reconstruction& model) {
  ModelMergeStep step;
  step.num_images = other.NumRegImages();
  step.rigs_refused = !RigsMergeable(other, model);
  return step;
}

// The correspondences of `corr` that agree with `model_from_other`: the
// mapped point within max_relative_error of its depth of the model's point.
std::vector<bool> Agreeing(const std::vector<Correspondence>& corr,
                           const Sim3d& model_from_other,
                           const ModelMergeOptions& options, size_t* count) {
  std::vector<bool> inliers(corr.size(), false);
  *count = 0;
  for (size_t k = 0; k < corr.size(); ++k) {
    const Correspondence& c = corr[k];
    if (c.model_depth > 0 &&
        (model_from_other * c.other_xyz - c.model_xyz).norm() <=
            options.max_relative_error * c.model_depth) {
      inliers[k] = true;
      ++*count;
    }
  }
  return inliers;
}

// Local optimisation (LO-RANSAC, Chum, Matas and Kittler, 2003) of the
// similarity one shared image gave: least-squares refits (Umeyama, through
// EstimateSimilarity) to the agreeing points of every shared image, each
// kept while at least as many points agree with it. One image's pose fixes
// the rotation of the whole merged sub-model as well as that image is
// posed; the points of all shared images fix it as well as the overlap
// does.
void RefineOnInliers(const std::vector<Correspondence>& corr,
                     const ModelMergeOptions& options, Sim3d* model_from_other,
                     std::vector<bool>* inliers, size_t* num_inliers) {
  for (int round = 0; round < options.num_refits; ++round) {
    std::vector<Eigen::Vector3d> source, target;
    for (size_t k = 0; k < corr.size(); ++k) {
      if (!(*inliers)[k]) continue;
      source.push_back(corr[k].other_xyz);
      target.push_back(corr[k].model_xyz);
    }
    Sim3d refit;
    if (!EstimateSimilarity(source, target, &refit)) return;
    size_t count = 0;
    std::vector<bool> agree = Agreeing(corr, refit, options, &count);
    if (count < *num_inliers) return;
    const bool same = agree == *inliers;
    *model_from_other = refit;
    *inliers = std::move(agree);
    *num_inliers = count;
    if (same) return;
  }
}

}  // namespace

ModelMergeStep MergeInto(const Reconstruction& other,
                         const ModelMergeOptions& options,
                         Reconstruction* model) {
  ModelMergeStep step = FirstCounts(other, *model);
  if (step.rigs_refused) return step;
  const std::vector<Correspondence> corr =
      SharedObservations(other, *model, &step.num_common_images);
  step.num_correspondences = corr.size();
  if (corr.size() < static_cast<size_t>(options.min_inliers)) return step;
  // One similarity per shared image: its two poses and the median depth
  // ratio of its shared points.
  std::map<ImageId, std::vector<double>> ratios;
  for (const Correspondence& c : corr) {
    if (c.model_depth > 0 && c.other_depth > 0) {
      ratios[c.image].push_back(c.model_depth / c.other_depth);
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
    size_t count = 0;
    std::vector<bool> inliers =
        Agreeing(corr, model_from_other, options, &count);
    if (count > step.num_inliers) {
      step.num_inliers = count;
      best_inliers = std::move(inliers);
      best = model_from_other;
    }
  }
  if (options.refine_similarity && step.num_inliers > 0) {
    RefineOnInliers(corr, options, &best, &best_inliers, &step.num_inliers);
  }
  JoinIfAgreed(other, corr, best_inliers, best, options, &step, model);
  return step;
}

ModelMergeStep MergeThroughMatches(const Reconstruction& other,
                                   const std::vector<PairMatches>& pairs,
                                   const ModelMergeOptions& options,
                                   Reconstruction* model) {
  ModelMergeStep step = FirstCounts(other, *model);
  if (step.rigs_refused) return step;
  const std::vector<Correspondence> corr =
      MatchedObservations(other, *model, pairs, &step.num_pairs);
  step.num_correspondences = corr.size();
  if (corr.size() < static_cast<size_t>(options.min_inliers)) return step;
  std::vector<Eigen::Vector3d> source, target;
  std::vector<double> distances;
  for (const Correspondence& c : corr) {
    source.push_back(c.other_xyz);
    target.push_back(c.model_xyz);
    distances.push_back(options.max_relative_error * c.model_depth);
  }
  const SimilarityAlignment fit = AlignSimilarityRobust(
      source, target, distances, SimilarityAlignmentOptions());
  if (!fit.success) return step;
  step.num_inliers = fit.num_inliers;
  JoinIfAgreed(other, corr, fit.inliers, fit.target_from_source, options,
               &step, model);
  return step;
}

size_t LargestModelIndex(const std::vector<Reconstruction>& models) {
  size_t largest = 0;
  for (size_t i = 1; i < models.size(); ++i) {
    if (models[i].NumRegImages() > models[largest].NumRegImages()) largest = i;
  }
  return largest;
}

ModelMergeResult MergeModels(const std::vector<Reconstruction>& models,
                             const ModelMergeOptions& options,
                             std::optional<size_t> base) {
  ThrowUnless(!models.empty(), "MergeModels: no model");
  ModelMergeResult result;
  if (base) {
    ThrowUnless(*base < models.size(), "MergeModels: no such base model");
    result.base = *base;
  } else {
    result.base = LargestModelIndex(models);
  }
  result.model = models[result.base];
  std::vector<size_t> left;
  for (size_t i = 0; i < models.size(); ++i) {
    if (i != result.base) left.push_back(i);
  }
  std::stable_sort(left.begin(), left.end(), [&](size_t a, size_t b) {
    return models[a].NumRegImages() > models[b].NumRegImages();
  });
  // The last attempt on each sub-model not merged.
  std::map<size_t, ModelMergeStep> failed;
  bool progress = true;
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

void RemoveImages(const std::set<ImageId>& image_ids, Reconstruction* model) {
  auto removed = [&](ImageId id) { return image_ids.count(id) > 0; };
  // The number of a frame's images (camera data) and of those removed.
  auto count = [&](const Frame& frame) {
    std::pair<size_t, size_t> n{0, 0};
    for (const FrameData& d : frame.data) {
      if (d.sensor.type != SensorType::kCamera) continue;
      ++n.first;
      n.second += removed(static_cast<ImageId>(d.data_id));
    }
    return n;
  };
  if (model->frames) {
    for (const Frame& frame : *model->frames) {
      const auto [num_images, num_removed] = count(frame);
      ThrowUnless(num_removed == 0 || num_removed == num_images,
                  StrCat("RemoveImages: frame ", frame.frame_id,
                         " holds images of a rig that are not all removed"));
    }
    std::vector<Frame>& frames = *model->frames;
    frames.erase(std::remove_if(frames.begin(), frames.end(),
                                [&](const Frame& f) {
                                  return count(f).second > 0;
                                }),
                 frames.end());
  }
  for (ImageId id : image_ids) model->images.erase(id);
  for (auto it = model->points3D.begin(); it != model->points3D.end();) {
    std::vector<TrackElement>& track = it->second.track;
    track.erase(std::remove_if(track.begin(), track.end(),
                               [&](const TrackElement& e) {
                                 return removed(e.image_id);
                               }),
                track.end());
    it = track.size() >= 2 ? std::next(it) : ErasePoint(it, model);
  }
}

std::vector<Reconstruction> DisjointModels(const Reconstruction& base,
                                           std::vector<Reconstruction> models,
                                           size_t min_images) {
  std::stable_sort(models.begin(), models.end(),
                   [](const Reconstruction& a, const Reconstruction& b) {
                     return a.NumRegImages() > b.NumRegImages();
                   });
  std::set<ImageId> taken;
  for (const auto& [id, image] : base.images) taken.insert(id);
  std::vector<Reconstruction> out;
  for (Reconstruction& model : models) {
    std::set<ImageId> shared;
    for (const auto& [id, image] : model.images) {
      if (taken.count(id)) shared.insert(id);
    }
    try {
      RemoveImages(shared, &model);
      // Images that kept no observation are no longer part of the model.
      std::set<ImageId> empty;
      for (const auto& [id, image] : model.images) {
        if (std::none_of(image.points2D.begin(), image.points2D.end(),
                         [](const Point2D& p) {
                           return p.point3D_id != kInvalidPoint3DId;
                         })) {
          empty.insert(id);
        }
      }
      RemoveImages(empty, &model);
    } catch (const Error&) {
      continue;
    }
    if (model.NumRegImages() < min_images) continue;
    for (const auto& [id, image] : model.images) taken.insert(id);
    out.push_back(std::move(model));
  }
  return out;
}

std::vector<Reconstruction> UnmergedModels(
    const std::vector<Reconstruction>& models, const ModelMergeResult& result) {
  std::vector<Reconstruction> left;
  for (const ModelMergeStep& step : result.steps) {
    if (!step.merged) left.push_back(models.at(step.model));
  }
  return left;
}

}  // namespace hisfm
