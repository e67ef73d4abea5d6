#include "hisfm/recon/conflict_join.h"

#include <algorithm>
#include <cmath>
#include <iterator>
#include <numeric>
#include <optional>
#include <unordered_map>

#include "hisfm/eval/similarity_alignment.h"
#include "hisfm/util/error.h"
#include "hisfm/util/string_util.h"
#include "hisfm/verify/camera_projection.h"

namespace hisfm {

void ConflictJoinOptions::Check() const {
  HISFM_CHECK_OPTION(min_pair_correspondences, min_pair_correspondences >= 3,
                     ">= 3");
  HISFM_CHECK_OPTION(min_pair_inlier_share,
                     min_pair_inlier_share >= 0.0 && min_pair_inlier_share <= 1.0,
                     "in [0, 1]");
  HISFM_CHECK_OPTION(pair_fit_iterations, pair_fit_iterations >= 1, ">= 1");
  HISFM_CHECK_OPTION(max_rotation_deg,
                     max_rotation_deg > 0.0 && max_rotation_deg <= 180.0,
                     "in (0, 180]");
  HISFM_CHECK_OPTION(max_hypotheses, max_hypotheses >= 1, ">= 1");
  HISFM_CHECK_OPTION(min_votes, min_votes >= 1, ">= 1");
  HISFM_CHECK_OPTION(min_expected, min_expected >= 1, ">= 1");
  HISFM_CHECK_OPTION(min_share_ratio,
                     std::isfinite(min_share_ratio) && min_share_ratio >= 1.0,
                     "finite and >= 1");
  HISFM_CHECK_OPTION(min_found_share,
                     min_found_share >= 0.0 && min_found_share <= 1.0,
                     "in [0, 1]");
}

namespace {

// Seed of every pair's RANSAC fit, so that a run is reproducible.
constexpr uint32_t kPairFitSeed = 1;

// The join one pair proposes: the similarity of its own matched 3D points.
struct Proposal {
  size_t pair = 0;  // index into the pairs given
  ImageId model_image = kInvalidImageId;
  ImageId other_image = kInvalidImageId;
  Sim3d model_from_other;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();  // other's frame
  double depth = 0.0;  // mean depth of its agreeing points, model image
  size_t num_inliers = 0;
  // The pair's matches as (model keypoint, other keypoint) and (other
  // keypoint, model keypoint), each sorted.
  std::vector<std::pair<Point2DIdx, Point2DIdx>> model_to_other;
  std::vector<std::pair<Point2DIdx, Point2DIdx>> other_to_model;
};

// The point keypoint `idx` of `image` observes in `model`, if any.
const Point3D* ObservedPoint(const Reconstruction& model, const Image& image,
                             Point2DIdx idx) {
  if (idx >= image.points2D.size()) return nullptr;
  const auto it = model.points3D.find(image.points2D[idx].point3D_id);
  return it == model.points3D.end() ? nullptr : &it->second;
}

std::optional<Proposal> Propose(const Reconstruction& model,
                                const Reconstruction& other,
                                const PairMatches& pm, size_t index,
                                const ConflictJoinOptions& options,
                                double max_relative_error) {
  Proposal p;
  p.pair = index;
  p.model_image = pm.pair.image_id1;
  p.other_image = pm.pair.image_id2;
  bool swapped = false;
  if (!model.images.count(p.model_image) ||
      !other.images.count(p.other_image)) {
    std::swap(p.model_image, p.other_image);
    swapped = true;
  }
  const auto model_it = model.images.find(p.model_image);
  const auto other_it = other.images.find(p.other_image);
  if (model_it == model.images.end() || other_it == other.images.end()) {
    return std::nullopt;
  }
  const Image& model_image = model_it->second;
  const Image& other_image = other_it->second;
  std::vector<Eigen::Vector3d> source, target;
  std::vector<double> distances, depths;
  for (const FeatureMatch& m : pm.matches) {
    const Point2DIdx k_model = swapped ? m.idx2 : m.idx1;
    const Point2DIdx k_other = swapped ? m.idx1 : m.idx2;
    p.model_to_other.push_back({k_model, k_other});
    p.other_to_model.push_back({k_other, k_model});
    const Point3D* x_model = ObservedPoint(model, model_image, k_model);
    const Point3D* x_other = ObservedPoint(other, other_image, k_other);
    if (x_model == nullptr || x_other == nullptr) continue;
    const double depth = (model_image.cam_from_world * x_model->xyz).z();
    if (!(depth > 0.0)) continue;
    source.push_back(x_other->xyz);
    target.push_back(x_model->xyz);
    depths.push_back(depth);
    distances.push_back(max_relative_error * depth);
  }
  if (source.size() < static_cast<size_t>(options.min_pair_correspondences)) {
    return std::nullopt;
  }
  SimilarityAlignmentOptions ransac;
  ransac.num_iterations = options.pair_fit_iterations;
  ransac.random_seed = kPairFitSeed;
  const SimilarityAlignment fit =
      AlignSimilarityRobust(source, target, distances, ransac);
  if (!fit.success || static_cast<double>(fit.num_inliers) <
                          options.min_pair_inlier_share * source.size()) {
    return std::nullopt;
  }
  p.model_from_other = fit.target_from_source;
  p.num_inliers = fit.num_inliers;
  for (size_t k = 0; k < source.size(); ++k) {
    if (!fit.inliers[k]) continue;
    p.centroid += source[k];
    p.depth += depths[k];
  }
  p.centroid /= static_cast<double>(fit.num_inliers);
  p.depth /= static_cast<double>(fit.num_inliers);
  std::sort(p.model_to_other.begin(), p.model_to_other.end());
  std::sort(p.other_to_model.begin(), p.other_to_model.end());
  return p;
}

// Whether `p`'s own similarity agrees with `join`.
bool Votes(const Proposal& p, const Sim3d& join, double max_rotation_rad,
           double max_relative_error) {
  if (p.model_from_other.rotation.angularDistance(join.rotation) >
      max_rotation_rad) {
    return false;
  }
  return (p.model_from_other * p.centroid - join * p.centroid).norm() <=
         max_relative_error * p.depth;
}

using Projections = std::unordered_map<CameraId, CameraProjection>;

Projections CameraProjections(const Reconstruction& model) {
  Projections out;
  for (const auto& [id, camera] : model.cameras) {
    out.emplace(id, CameraProjection(camera.model_id, camera.width,
                                     camera.height, camera.params));
  }
  return out;
}

// Counts the unique points of `from`'s image `from_id` that land in `to`'s
// image `to_id` (in front of it, inside the image) under `to_from_from`
// (expected), and those of them the pair matched in agreement with the
// join (found): to a keypoint that observes a point of `to` within
// max_relative_error of the landing point's depth of it. A unique point
// matched only to keypoints that observe no point of `to` is left out of
// both counts (the match can neither confirm nor refute the join). A match
// that ties the unique point to another point of `to` is evidence against
// the join, not for it (two photos near in a street match some clutter
// truly, whatever shift of the facade a join proposes).
void Predict(const Reconstruction& from, ImageId from_id,
             const std::unordered_set<Point3DId>& confusing,
             const std::vector<std::pair<Point2DIdx, Point2DIdx>>& matched,
             const Reconstruction& to, ImageId to_id,
             const Projections& to_cameras, const Sim3d& to_from_from,
             double max_relative_error, size_t* expected, size_t* found) {
  const Image& from_image = from.images.at(from_id);
  const Image& to_image = to.images.at(to_id);
  const auto camera = to_cameras.find(to_image.camera_id);
  ThrowUnless(camera != to_cameras.end(),
              StrCat("conflict join: image ", to_id, " has no camera"));
  for (size_t k = 0; k < from_image.points2D.size(); ++k) {
    const Point3DId id = from_image.points2D[k].point3D_id;
    const auto point = from.points3D.find(id);
    if (point == from.points3D.end() || confusing.count(id)) continue;
    const Eigen::Vector3d landing = to_from_from * point->second.xyz;
    const Eigen::Vector3d in_cam = to_image.cam_from_world * landing;
    if (!(in_cam.z() > 0.0)) continue;
    if (!camera->second.InImage(
            camera->second.NormalizedToPixel(in_cam.hnormalized()))) {
      continue;
    }
    const auto key = static_cast<Point2DIdx>(k);
    bool neutral = false;
    bool agrees = false;
    for (auto it = std::lower_bound(matched.begin(), matched.end(),
                                    std::make_pair(key, Point2DIdx{0}));
         it != matched.end() && it->first == key; ++it) {
      const Point3D* partner = ObservedPoint(to, to_image, it->second);
      if (partner == nullptr) {
        neutral = true;
      } else if ((partner->xyz - landing).norm() <=
                 max_relative_error * in_cam.z()) {
        agrees = true;
      }
    }
    if (neutral && !agrees) continue;
    ++*expected;
    if (agrees) ++*found;
  }
}

}  // namespace

LeastConflictJoin FindLeastConflictJoin(
    const Reconstruction& model, const Reconstruction& other,
    const std::vector<PairMatches>& pairs,
    const std::unordered_set<Point3DId>& model_confusing,
    const std::unordered_set<Point3DId>& other_confusing,
    const ConflictJoinOptions& options, double max_relative_error) {
  options.Check();
  LeastConflictJoin out;
  ConflictJoinStep& step = out.step;
  step.merge.num_images = other.NumRegImages();
  std::vector<Proposal> proposals;
  for (size_t i = 0; i < pairs.size(); ++i) {
    std::optional<Proposal> p =
        Propose(model, other, pairs[i], i, options, max_relative_error);
    if (p) proposals.push_back(std::move(*p));
  }
  step.num_fitted_pairs = proposals.size();
  std::vector<size_t> order(proposals.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(), [&](size_t a, size_t b) {
    return proposals[a].num_inliers > proposals[b].num_inliers;
  });
  const Projections model_cameras = CameraProjections(model);
  const Projections other_cameras = CameraProjections(other);
  const double max_rotation = options.max_rotation_deg * M_PI / 180.0;
  std::vector<bool> covered(proposals.size(), false);
  // The scored families: the share of predicted unique points found, the
  // voters (sorted), the join and its counts.
  struct Family {
    double share = 0.0;
    std::vector<size_t> voters;
    Sim3d join;
    size_t expected = 0;
    size_t found = 0;
  };
  std::vector<Family> families;
  for (const size_t seed : order) {
    if (covered[seed]) continue;
    if (step.num_hypotheses == static_cast<size_t>(options.max_hypotheses)) {
      break;
    }
    ++step.num_hypotheses;
    covered[seed] = true;
    const Sim3d join = proposals[seed].model_from_other;
    std::vector<size_t> voters;
    for (size_t k = 0; k < proposals.size(); ++k) {
      if (Votes(proposals[k], join, max_rotation, max_relative_error)) {
        voters.push_back(k);
        covered[k] = true;
      }
    }
    if (voters.size() < static_cast<size_t>(options.min_votes)) continue;
    const Sim3d other_from_model = join.Inverse();
    size_t expected = 0, found = 0;
    for (const size_t k : voters) {
      const Proposal& p = proposals[k];
      Predict(model, p.model_image, model_confusing, p.model_to_other, other,
              p.other_image, other_cameras, other_from_model,
              max_relative_error, &expected, &found);
      Predict(other, p.other_image, other_confusing, p.other_to_model, model,
              p.model_image, model_cameras, join, max_relative_error,
              &expected, &found);
    }
    if (expected < static_cast<size_t>(options.min_expected)) continue;
    families.push_back({static_cast<double>(found) / expected,
                        std::move(voters), join, expected, found});
  }
  // The best family (the first on a tie), and the best of those that share
  // no voting pair with it: a family that shares voters proposes nearly the
  // same join (a drifted piece's true join splits into several such, each
  // within max_rotation_deg of its seed), not a rival one.
  const Family* best = nullptr;
  for (const Family& f : families) {
    if (!best || f.share > best->share) best = &f;
  }
  if (!best) return out;
  out.model_from_other = best->join;
  step.num_votes = best->voters.size();
  step.num_expected = best->expected;
  step.num_found = best->found;
  for (const Family& f : families) {
    if (&f == best) continue;
    std::vector<size_t> shared;
    std::set_intersection(f.voters.begin(), f.voters.end(),
                          best->voters.begin(), best->voters.end(),
                          std::back_inserter(shared));
    if (shared.empty()) {
      step.next_found_share = std::max(step.next_found_share, f.share);
    }
  }
  for (const size_t k : best->voters) {
    out.voting_pairs.push_back(proposals[k].pair);
  }
  out.stands_out =
      !best->voters.empty() && best->share >= options.min_found_share &&
      best->share >= options.min_share_ratio * step.next_found_share;
  return out;
}

ConflictJoinStep JoinByLeastConflict(
    const Reconstruction& other, const std::vector<PairMatches>& pairs,
    const std::unordered_set<Point3DId>& model_confusing,
    const std::unordered_set<Point3DId>& other_confusing,
    const ConflictJoinOptions& options, const ModelMergeOptions& merge,
    Reconstruction* model) {
  merge.Check();
  const LeastConflictJoin best =
      FindLeastConflictJoin(*model, other, pairs, model_confusing,
                            other_confusing, options, merge.max_relative_error);
  ConflictJoinStep step = best.step;
  if (!best.stands_out) return step;
  std::vector<PairMatches> chosen;
  chosen.reserve(best.voting_pairs.size());
  for (const size_t k : best.voting_pairs) chosen.push_back(pairs[k]);
  step.merge = MergeThroughMatches(other, chosen, merge, model);
  return step;
}

}  // namespace hisfm
