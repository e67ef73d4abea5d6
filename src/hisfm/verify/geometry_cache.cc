#include "hisfm/verify/geometry_cache.h"

#include "hisfm/util/error.h"
#include "hisfm/util/string_util.h"
#include "hisfm/verify/two_view_pose.h"

namespace hisfm {

void GeometryCacheOptions::Check() const {
  HISFM_CHECK_OPTION(keypoint_radius_px, keypoint_radius_px > 0, "> 0");
  relative_pose.Check();
}

GeometryCache::GeometryCache(const Database& database,
                             const ViewGraph& graph,
                             const GeometryCacheOptions& options)
    : database_(database), graph_(graph), options_(options) {
  options_.Check();
  for (const DatabaseCamera& c : database_.ReadCameras()) {
    cameras_.emplace(c.camera_id, c);
  }
  for (const DatabaseImage& im : database_.ReadImages()) {
    camera_of_image_[im.image_id] = im.camera_id;
  }
}

const ImageGeometry& GeometryCache::Image(ImageId image_id) {
  std::lock_guard<std::mutex> lock(mutex_);
  return ImageLocked(image_id);
}

const ImageGeometry& GeometryCache::ImageLocked(ImageId image_id) {
  auto it = images_.find(image_id);
  if (it != images_.end()) return *it->second;
  auto cam = camera_of_image_.find(image_id);
  ThrowUnless(cam != camera_of_image_.end(),
              StrCat("unknown image id ", image_id));
  auto camera = cameras_.find(cam->second);
  ThrowUnless(camera != cameras_.end(),
              StrCat("image ", image_id, " names a missing camera"));
  auto g = std::make_unique<ImageGeometry>();
  g->image_id = image_id;
  g->camera = CameraProjection(camera->second);
  const Keypoints keypoints = database_.ReadKeypoints(image_id);
  g->pixels.resize(keypoints.rows());
  g->normalized.resize(keypoints.rows());
  for (int r = 0; r < keypoints.rows(); ++r) {
    g->pixels[r] = Eigen::Vector2d(keypoints(r, 0), keypoints(r, 1));
    g->normalized[r] = g->camera.PixelToNormalized(g->pixels[r]);
  }
  auto degree = degrees_.find(image_id);
  if (degree != degrees_.end()) g->degree = degree->second;
  g->degree.resize(g->pixels.size(), 0);
  g->grid = KeypointGrid(g->pixels, static_cast<double>(g->camera.width()),
                         static_cast<double>(g->camera.height()),
                         options_.keypoint_radius_px);
  return *images_.emplace(image_id, std::move(g)).first->second;
}

bool GeometryCache::HasPair(ImageId a, ImageId b) const {
  return a != b && graph_.HasImage(a) && graph_.HasImage(b) &&
         graph_.Weight(a, b) > 0;
}

std::shared_ptr<const PairGeometry> GeometryCache::Stored(
    const ImagePair& pair) {
  std::unique_lock<std::mutex> lock(mutex_);
  auto it = stored_.find(pair);
  if (it != stored_.end()) return it->second;
  const TwoViewGeometry g =
      database_.ReadTwoViewGeometry(pair.image_id1, pair.image_id2);
  const ImageGeometry& im1 = ImageLocked(pair.image_id1);
  const ImageGeometry& im2 = ImageLocked(pair.image_id2);
  lock.unlock();
  auto out = std::make_shared<PairGeometry>();
  out->from = pair.image_id1;
  out->to = pair.image_id2;
  out->from_to.assign(im1.normalized.size(), PairGeometry::kNoMatch);
  out->to_from.assign(im2.normalized.size(), PairGeometry::kNoMatch);
  std::vector<Eigen::Vector2d> x1, x2;
  for (const FeatureMatch& m : g.inlier_matches) {
    if (m.idx1 >= im1.normalized.size() || m.idx2 >= im2.normalized.size()) {
      continue;
    }
    out->matches.push_back(m);
    out->from_to[m.idx1] = static_cast<int32_t>(m.idx2);
    out->to_from[m.idx2] = static_cast<int32_t>(m.idx1);
    x1.push_back(im1.normalized[m.idx1]);
    x2.push_back(im2.normalized[m.idx2]);
  }
  const Eigen::Matrix3d E =
      EssentialOfGeometry(g, im1.camera.K(), im2.camera.K());
  RelativePoseOptions pose_options = options_.relative_pose;
  pose_options.seed ^= static_cast<uint32_t>(
      ImagePairToPairId(pair.image_id1, pair.image_id2) * 2654435761u);
  const double focal =
      0.5 * (im1.camera.MeanFocal() + im2.camera.MeanFocal());
  out->hypotheses = EstimateRelativePose(E, x1, x2, focal, pose_options);
  lock.lock();
  return stored_.emplace(pair, out).first->second;
}

std::shared_ptr<const PairGeometry> GeometryCache::Pair(ImageId a, ImageId b) {
  const ImagePair pair(a, b);
  std::shared_ptr<const PairGeometry> stored = Stored(pair);
  if (a == pair.image_id1) return stored;
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = reversed_.find(pair);
  if (it != reversed_.end()) return it->second;
  auto out = std::make_shared<PairGeometry>();
  out->from = a;
  out->to = b;
  out->matches.reserve(stored->matches.size());
  for (const FeatureMatch& m : stored->matches) {
    out->matches.push_back({m.idx2, m.idx1});
  }
  out->from_to = stored->to_from;
  out->to_from = stored->from_to;
  for (const RelativePoseHypothesis& h : stored->hypotheses) {
    out->hypotheses.push_back({h.cam2_from_cam1.Inverse(), h.num_support});
  }
  // The inverse of a unit-baseline pose has a unit baseline too.
  return reversed_.emplace(pair, out).first->second;
}

}  // namespace hisfm
