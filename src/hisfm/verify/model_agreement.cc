#include "hisfm/verify/model_agreement.h"

#include <cmath>
#include <unordered_map>

#include "hisfm/util/error.h"
#include "hisfm/util/parallel.h"
#include "hisfm/util/string_util.h"
#include "hisfm/verify/camera_projection.h"

namespace hisfm {

void ModelAgreementOptions::Check() const {
  HISFM_CHECK_OPTION(max_transfer_error, max_transfer_error > 0.0, "> 0");
  HISFM_CHECK_OPTION(min_agreeing_share,
                     min_agreeing_share >= 0.0 && min_agreeing_share <= 1.0,
                     "in [0, 1]");
  HISFM_CHECK_OPTION(min_testable, min_testable >= 1, ">= 1");
  HISFM_CHECK_OPTION(num_threads, num_threads >= 1, ">= 1");
}

namespace {

// Depth (model units) in front of a camera below which a point is behind it.
constexpr double kMinDepth = 1e-9;
// Pairs per block of the parallel visibility bound.
constexpr size_t kPairsPerBlock = 256;

struct ImageView {
  const Image* image = nullptr;
  const CameraProjection* camera = nullptr;
  double max_error = 0.0;  // pixels
};

enum class Transfer { kUntestable, kAgrees, kDisagrees };

// Transfers keypoint `from_idx` of `from` into `to` and compares it with
// keypoint `to_idx` there. Adds to the counts when the match is testable.
Transfer TransferOne(const Reconstruction& model, const ImageView& from,
                     Point2DIdx from_idx, const ImageView& to,
                     Point2DIdx to_idx, PairAgreement* agreement) {
  const auto& from_points = from.image->points2D;
  const auto& to_points = to.image->points2D;
  ThrowUnless(from_idx < from_points.size() && to_idx < to_points.size(),
              StrCat("model agreement: a match of images ",
                     from.image->image_id, " and ", to.image->image_id,
                     " indexes past the model's keypoints"));
  const Point3DId id = from_points[from_idx].point3D_id;
  if (id == kInvalidPoint3DId) return Transfer::kUntestable;
  const auto it = model.points3D.find(id);
  if (it == model.points3D.end()) return Transfer::kUntestable;
  const Eigen::Vector3d in_cam = to.image->cam_from_world * it->second.xyz;
  if (in_cam.z() <= kMinDepth) return Transfer::kUntestable;
  ++agreement->num_testable;
  const Eigen::Vector2d uv =
      to.camera->NormalizedToPixel(in_cam.hnormalized());
  if ((uv - to_points[to_idx].xy).norm() > to.max_error) {
    return Transfer::kDisagrees;
  }
  ++agreement->num_agreeing;
  return Transfer::kAgrees;
}

// Number of `points` (world) that project into `to`'s image, widened by its
// max_error, stopping once `enough` are found. A bound on a pair's agreeing
// transfers as long as no keypoint takes part in two of its matches, which
// colmap's cross-checked matching ensures.
int CountSeen(const std::vector<Eigen::Vector3d>& points, const ImageView& to,
              int enough) {
  const double margin = -to.max_error;
  int seen = 0;
  for (const Eigen::Vector3d& x : points) {
    const Eigen::Vector3d in_cam = to.image->cam_from_world * x;
    if (in_cam.z() <= kMinDepth) continue;
    if (to.camera->InImage(to.camera->NormalizedToPixel(in_cam.hnormalized()),
                           margin) &&
        ++seen >= enough) {
      break;
    }
  }
  return seen;
}

}  // namespace

std::vector<PairAgreement> JudgePairsAgainstModel(
    const Database& database, const std::vector<ImagePair>& pairs,
    const Reconstruction& model, const ModelAgreementOptions& options) {
  options.Check();
  std::unordered_map<CameraId, CameraProjection> cameras;
  for (const auto& [id, camera] : model.cameras) {
    cameras.emplace(id, CameraProjection(camera.model_id, camera.width,
                                         camera.height, camera.params));
  }
  std::unordered_map<ImageId, ImageView> views;
  for (const auto& [id, image] : model.images) {
    const auto cam = cameras.find(image.camera_id);
    ThrowUnless(cam != cameras.end(),
                StrCat("model agreement: image ", id, " has no camera"));
    const double diagonal = std::hypot(static_cast<double>(cam->second.width()),
                                       static_cast<double>(cam->second.height()));
    views[id] = {&image, &cam->second, options.max_transfer_error * diagonal};
  }
  std::vector<ImagePair> inside;
  for (const ImagePair& pair : pairs) {
    if (views.count(pair.image_id1) && views.count(pair.image_id2)) {
      inside.push_back(pair);
    }
  }
  // Each image's 3D points, for the bound on agreeing matches.
  std::unordered_map<ImageId, std::vector<Eigen::Vector3d>> seen_points;
  for (const auto& [id, image] : model.images) {
    std::vector<Eigen::Vector3d>& points = seen_points[id];
    for (const Point2D& p : image.points2D) {
      if (p.point3D_id == kInvalidPoint3DId) continue;
      const auto it = model.points3D.find(p.point3D_id);
      if (it != model.points3D.end()) points.push_back(it->second.xyz);
    }
  }
  const int needed = static_cast<int>(
      std::ceil(options.min_agreeing_share * options.min_testable));
  std::vector<char> can_agree(inside.size());
  ParallelFor(
      inside.size(), options.num_threads,
      [&](size_t k) {
        const ImagePair& pair = inside[k];
        const int forward = CountSeen(seen_points.at(pair.image_id1),
                                      views.at(pair.image_id2), needed);
        const int backward =
            forward >= needed
                ? 0
                : CountSeen(seen_points.at(pair.image_id2),
                            views.at(pair.image_id1), needed - forward);
        can_agree[k] = forward + backward >= needed;
      },
      kPairsPerBlock);
  std::vector<PairAgreement> result;
  result.reserve(inside.size());
  std::vector<ImagePair> to_read;
  for (size_t k = 0; k < inside.size(); ++k) {
    if (can_agree[k]) {
      to_read.push_back(inside[k]);
    } else {
      PairAgreement unjudged;
      unjudged.pair = inside[k];
      result.push_back(unjudged);
    }
  }
  inside = std::move(to_read);
  database.ForEachInlierMatches(
      inside, [&](const ImagePair& pair, FeatureMatchSpan matches) {
        PairAgreement agreement;
        agreement.pair = pair;
        const ImageView& v1 = views.at(pair.image_id1);
        const ImageView& v2 = views.at(pair.image_id2);
        for (const FeatureMatch& m : matches) {
          const Transfer forward =
              TransferOne(model, v1, m.idx1, v2, m.idx2, &agreement);
          const Transfer backward =
              TransferOne(model, v2, m.idx2, v1, m.idx1, &agreement);
          if (forward != Transfer::kDisagrees &&
              backward != Transfer::kDisagrees &&
              (forward == Transfer::kAgrees || backward == Transfer::kAgrees)) {
            agreement.agreeing_matches.push_back(m);
          }
        }
        agreement.judged = agreement.num_testable >= options.min_testable;
        agreement.agrees =
            agreement.judged &&
            agreement.num_agreeing >=
                options.min_agreeing_share * agreement.num_testable;
        result.push_back(agreement);
      });
  return result;
}

}  // namespace hisfm
