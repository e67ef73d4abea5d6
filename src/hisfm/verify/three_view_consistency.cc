#include "hisfm/verify/three_view_consistency.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "hisfm/util/error.h"
#include "hisfm/verify/two_view_pose.h"

namespace hisfm {
namespace {

// Inliers voting on the cheirality of the pose decomposed from E.
constexpr size_t kMaxPoseVotes = 100;

}  // namespace

void ThreeViewOptions::Check() const {
  HISFM_CHECK_OPTION(max_error_px, max_error_px > 0, "> 0");
  HISFM_CHECK_OPTION(min_triangulation_angle_deg,
                     min_triangulation_angle_deg >= 0 &&
                     min_triangulation_angle_deg < 90,
                     "in [0, 90)");
  HISFM_CHECK_OPTION(min_scale_points, min_scale_points >= 1, ">= 1");
  HISFM_CHECK_OPTION(max_shared_points, max_shared_points >= 0, ">= 0");
}

PairGeometryCache::PairGeometryCache(const Database& database)
    : database_(database) {
  for (const DatabaseCamera& c : database_.ReadCameras()) {
    cameras_.emplace(c.camera_id, CameraProjection(c));
  }
  for (const DatabaseImage& im : database_.ReadImages()) {
    camera_of_image_[im.image_id] = im.camera_id;
  }
}

const std::vector<Eigen::Vector2d>& PairGeometryCache::Normalized(
    ImageId image_id) {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    auto it = normalized_.find(image_id);
    if (it != normalized_.end()) return it->second;
  }
  Keypoints keypoints;
  {
    const std::lock_guard<std::mutex> lock(read_mutex_);
    keypoints = database_.ReadKeypoints(image_id);
  }
  const CameraProjection& camera =
      cameras_.at(camera_of_image_.at(image_id));
  std::vector<Eigen::Vector2d> out(keypoints.rows());
  for (int r = 0; r < keypoints.rows(); ++r) {
    out[r] = camera.PixelToNormalized(
        Eigen::Vector2d(keypoints(r, 0), keypoints(r, 1)));
  }
  // (Another thread may have added it meanwhile: then its copy is kept.
  // Elements of an unordered_map keep their address when it grows.)
  const std::lock_guard<std::mutex> lock(mutex_);
  return normalized_.emplace(image_id, std::move(out)).first->second;
}

double PairGeometryCache::Focal(ImageId image_id) {
  return cameras_.at(camera_of_image_.at(image_id)).MeanFocal();
}

std::shared_ptr<const PairGeometryCache::PairGeometry> PairGeometryCache::Pair(
    const ImagePair& pair, bool keep) {
  {
    const std::lock_guard<std::mutex> lock(mutex_);
    auto it = pairs_.find(pair);
    if (it != pairs_.end()) return it->second;
  }
  TwoViewGeometry g;
  {
    const std::lock_guard<std::mutex> lock(read_mutex_);
    g = database_.ReadTwoViewGeometry(pair.image_id1, pair.image_id2);
  }
  auto out = std::make_shared<PairGeometry>();
  out->pair = g.pair;
  const std::vector<Eigen::Vector2d>& n1 = Normalized(g.pair.image_id1);
  const std::vector<Eigen::Vector2d>& n2 = Normalized(g.pair.image_id2);
  // The cheirality vote that picks the pose from E needs only a sample of
  // the inliers.
  const size_t step = std::max<size_t>(1, g.inlier_matches.size() /
                                              kMaxPoseVotes);
  std::vector<Eigen::Vector2d> x1, x2;
  out->to2.assign(n1.size(), PairGeometry::kNoMatch);
  out->to1.assign(n2.size(), PairGeometry::kNoMatch);
  for (size_t k = 0; k < g.inlier_matches.size(); ++k) {
    const FeatureMatch& m = g.inlier_matches[k];
    if (m.idx1 >= n1.size() || m.idx2 >= n2.size()) continue;
    out->to2[m.idx1] = static_cast<int32_t>(m.idx2);
    out->to1[m.idx2] = static_cast<int32_t>(m.idx1);
    if (k % step == 0) {
      x1.push_back(n1[m.idx1]);
      x2.push_back(n2[m.idx2]);
    }
  }
  const Eigen::Matrix3d E = EssentialOfGeometry(
      g, cameras_.at(camera_of_image_.at(g.pair.image_id1)).K(),
      cameras_.at(camera_of_image_.at(g.pair.image_id2)).K());
  out->has_pose = PoseFromEssential(E, x1, x2, &out->cam2_from_cam1) > 0;
  if (!keep) return out;
  const std::lock_guard<std::mutex> lock(mutex_);
  return pairs_.emplace(pair, out).first->second;
}

namespace {

using Projection = Eigen::Matrix<double, 3, 4>;

Projection ProjectionOf(const Rigid3d& cam_from_x) {
  Projection P;
  P.leftCols<3>() = cam_from_x.rotation.toRotationMatrix();
  P.col(3) = cam_from_x.translation;
  return P;
}

// Linear triangulation from `n` views (normalized coordinates): the least-
// squares solution of the DLT equations with the point's last homogeneous
// coordinate fixed to 1 (finite points only), via the 3x3 normal equations.
Eigen::Vector3d TriangulateLinear(const Projection* P, const Eigen::Vector2d* u,
                                  int n) {
  Eigen::Matrix3d AtA = Eigen::Matrix3d::Zero();
  Eigen::Vector3d Atb = Eigen::Vector3d::Zero();
  for (int v = 0; v < n; ++v) {
    for (int r = 0; r < 2; ++r) {
      const Eigen::Matrix<double, 1, 4> row = u[v](r) * P[v].row(2) -
                                              P[v].row(r);
      const Eigen::Vector3d a = row.head<3>().transpose();
      AtA += a * a.transpose();
      Atb -= a * row(3);
    }
  }
  const Eigen::LDLT<Eigen::Matrix3d> ldlt(AtA);
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) {
    return Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  }
  return ldlt.solve(Atb);
}

}  // namespace

ThreeViewResult MeasureThreeViewConsistency(
    PairGeometryCache& cache, const TrackConsistency& tracks,
    const PairGeometryCache::PairGeometry& xy, ImageId x, ImageId t,
    const ThreeViewOptions& options) {
  ThreeViewResult result;
  ThrowUnless(xy.pair.image_id1 == x || xy.pair.image_id2 == x,
              "three-view test: image is not in the pair");
  const ImageId y = xy.pair.image_id1 == x ? xy.pair.image_id2
                                           : xy.pair.image_id1;
  if (!xy.has_pose) return result;
  const std::shared_ptr<const PairGeometryCache::PairGeometry> xt =
      cache.Pair(ImagePair(x, t));
  if (!xt->has_pose) return result;
  // Poses in x's frame.
  const Rigid3d y_from_x = xy.pair.image_id1 == x
                               ? xy.cam2_from_cam1
                               : xy.cam2_from_cam1.Inverse();
  const Rigid3d t_from_x = xt->pair.image_id1 == x
                               ? xt->cam2_from_cam1
                               : xt->cam2_from_cam1.Inverse();
  const auto& x_to_y = xy.pair.image_id1 == x ? xy.to2 : xy.to1;
  const auto& x_to_t = xt->pair.image_id1 == x ? xt->to2 : xt->to1;
  const std::vector<Eigen::Vector2d>& nx = cache.Normalized(x);
  const std::vector<Eigen::Vector2d>& ny = cache.Normalized(y);
  const std::vector<Eigen::Vector2d>& nt = cache.Normalized(t);
  const Eigen::Vector3d center_t = t_from_x.Inverse().translation;
  // angle < min_angle <=> cos(angle) > cos(min_angle): no acos per point.
  const double min_angle = options.min_triangulation_angle_deg * M_PI / 180.0;
  const double cos_min_angle = std::cos(min_angle);
  const Eigen::Matrix3d R_yx = y_from_x.rotation.toRotationMatrix();
  const Projection P_xt[2] = {ProjectionOf(Rigid3d()), ProjectionOf(t_from_x)};

  struct Shared {
    Eigen::Vector2d u[3];  // x, t, y
  };
  std::vector<Shared> shared;
  std::vector<double> scales;
  // Keypoints of x matched in both pairs.
  std::vector<uint32_t> candidates;
  const size_t num_x = std::min(x_to_t.size(), x_to_y.size());
  for (size_t kx = 0; kx < num_x; ++kx) {
    if (x_to_t[kx] != PairGeometryCache::PairGeometry::kNoMatch &&
        x_to_y[kx] != PairGeometryCache::PairGeometry::kNoMatch) {
      candidates.push_back(static_cast<uint32_t>(kx));
    }
  }
  // Scale points are distinctive candidates: too few, and the test is
  // silent whatever the triangulation (common where dense matching has
  // joined most tracks into inconsistent ones).
  const TrackConsistency::ImageKeypoints x_keypoints = tracks.KeypointsOf(x);
  int num_distinctive = 0;
  for (const uint32_t kx : candidates) {
    num_distinctive += x_keypoints.IsDistinctive(kx);
  }
  if (num_distinctive < options.min_scale_points) return result;
  // Every distinctive candidate fixes the scale; the consistency is counted
  // on max_shared_points evenly spaced candidates (candidate c is one if
  // floor(c m / n) steps up at c).
  const size_t n = candidates.size();
  const size_t m = options.max_shared_points > 0
                       ? std::min(n, static_cast<size_t>(
                                         options.max_shared_points))
                       : n;
  for (size_t c = 0; c < n; ++c) {
    const uint32_t kx = candidates[c];
    const bool counted = (c + 1) * m / n > c * m / n;
    const bool distinctive = x_keypoints.IsDistinctive(kx);
    if (!counted && !distinctive) continue;
    const int32_t kt = x_to_t[kx];
    const int32_t ky = x_to_y[kx];
    const Eigen::Vector2d uxt[2] = {nx[kx], nt[kt]};
    const Eigen::Vector3d X = TriangulateLinear(P_xt, uxt, 2);
    if (!X.allFinite() || X.z() <= 0 || (t_from_x * X).z() <= 0) continue;
    {
      // The angle at X between the rays to the centres of x and t.
      const Eigen::Vector3d r2 = X - center_t;
      const double n = X.norm() * r2.norm();
      const bool too_small =
          n <= 0 ? min_angle > 0
                 : std::clamp(X.dot(r2) / n, -1.0, 1.0) > cos_min_angle;
      if (too_small) continue;
    }
    if (counted) shared.push_back({{nx[kx], nt[kt], ny[ky]}});
    if (!distinctive) continue;
    // Scale s of y's baseline that puts X on y's ray: u x (R X + s t) = 0.
    const Eigen::Vector3d u = ny[ky].homogeneous();
    const Eigen::Vector3d a = u.cross(R_yx * X);
    const Eigen::Vector3d b = u.cross(y_from_x.translation);
    if (b.squaredNorm() > 1e-12) scales.push_back(-a.dot(b) / b.squaredNorm());
  }
  result.num_shared = static_cast<int>(shared.size());
  result.num_scale_points = static_cast<int>(scales.size());
  if (result.num_scale_points < options.min_scale_points) return result;
  std::nth_element(scales.begin(), scales.begin() + scales.size() / 2,
                   scales.end());
  const double scale = scales[scales.size() / 2];
  const Projection P[3] = {
      ProjectionOf(Rigid3d()), ProjectionOf(t_from_x),
      ProjectionOf(Rigid3d(y_from_x.rotation, scale * y_from_x.translation))};
  const double focal[3] = {cache.Focal(x), cache.Focal(t), cache.Focal(y)};
  for (const Shared& s : shared) {
    const Eigen::Vector3d X = TriangulateLinear(P, s.u, 3);
    if (!X.allFinite()) continue;
    bool ok = true;
    for (int v = 0; v < 3 && ok; ++v) {
      const Eigen::Vector3d Y = P[v] * X.homogeneous();
      ok = Y.z() > 0 &&
           (Y.hnormalized() - s.u[v]).norm() * focal[v] < options.max_error_px;
    }
    result.num_consistent += ok;
  }
  result.judged = true;
  result.fraction =
      static_cast<double>(result.num_consistent) / result.num_shared;
  return result;
}

}  // namespace hisfm
