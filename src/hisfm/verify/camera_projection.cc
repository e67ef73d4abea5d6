#include "hisfm/verify/camera_projection.h"

#include <Eigen/Dense>

#include "hisfm/util/error.h"

namespace hisfm {

namespace {

int NumParams(int model_id) {
  switch (model_id) {
    case 0:
      return 3;
    case 1:
      return 4;
    case 2:
      return 4;
    case 3:
      return 5;
    case 4:
      return 8;
    default:
      return -1;
  }
}

}  // namespace

CameraProjection::CameraProjection(const DatabaseCamera& camera)
    : CameraProjection(camera.model_id, camera.width, camera.height,
                       camera.params) {}

CameraProjection::CameraProjection(int model_id, uint64_t width,
                                   uint64_t height,
                                   const std::vector<double>& p)
    : width_(width), height_(height) {
  ThrowUnless(IsSupportedModel(model_id),
              StrCat("camera model id ", model_id,
                     " is not supported by the disambiguator (supported: "
                     "SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL, RADIAL, "
                     "OPENCV)"));
  ThrowUnless(static_cast<int>(p.size()) == NumParams(model_id),
              StrCat("camera model id ", model_id, " needs ",
                     NumParams(model_id), " parameters, got ", p.size()));
  switch (model_id) {
    case 0:
      fx_ = fy_ = p[0];
      cx_ = p[1];
      cy_ = p[2];
      break;
    case 1:
      fx_ = p[0];
      fy_ = p[1];
      cx_ = p[2];
      cy_ = p[3];
      break;
    case 2:
      fx_ = fy_ = p[0];
      cx_ = p[1];
      cy_ = p[2];
      k1_ = p[3];
      break;
    case 3:
      fx_ = fy_ = p[0];
      cx_ = p[1];
      cy_ = p[2];
      k1_ = p[3];
      k2_ = p[4];
      break;
    case 4:
      fx_ = p[0];
      fy_ = p[1];
      cx_ = p[2];
      cy_ = p[3];
      k1_ = p[4];
      k2_ = p[5];
      p1_ = p[6];
      p2_ = p[7];
      break;
  }
  ThrowUnless(fx_ > 0 && fy_ > 0, "camera focal length must be positive");
}

bool CameraProjection::IsSupportedModel(int model_id) {
  return NumParams(model_id) > 0;
}

Eigen::Vector2d CameraProjection::Distort(const Eigen::Vector2d& xy) const {
  const double x = xy.x(), y = xy.y();
  const double r2 = x * x + y * y;
  const double radial = 1.0 + k1_ * r2 + k2_ * r2 * r2;
  const double dx = 2.0 * p1_ * x * y + p2_ * (r2 + 2.0 * x * x);
  const double dy = p1_ * (r2 + 2.0 * y * y) + 2.0 * p2_ * x * y;
  return Eigen::Vector2d(x * radial + dx, y * radial + dy);
}

Eigen::Vector2d CameraProjection::NormalizedToPixel(
    const Eigen::Vector2d& xy) const {
  const Eigen::Vector2d d = Distort(xy);
  return Eigen::Vector2d(fx_ * d.x() + cx_, fy_ * d.y() + cy_);
}

Eigen::Vector2d CameraProjection::PixelToNormalized(
    const Eigen::Vector2d& uv) const {
  const Eigen::Vector2d target((uv.x() - cx_) / fx_, (uv.y() - cy_) / fy_);
  if (k1_ == 0 && k2_ == 0 && p1_ == 0 && p2_ == 0) return target;
  // Fixed-point iteration x <- target - (Distort(x) - x), as COLMAP's
  // IterativeUndistortion does for small distortions; a few Newton-free
  // steps converge to well below a pixel for the usual k.
  Eigen::Vector2d x = target;
  for (int it = 0; it < 50; ++it) {
    const Eigen::Vector2d delta = Distort(x) - x;
    const Eigen::Vector2d next = target - delta;
    if ((next - x).squaredNorm() < 1e-20) {
      x = next;
      break;
    }
    x = next;
  }
  return x;
}

Eigen::Matrix3d CameraProjection::K() const {
  Eigen::Matrix3d k = Eigen::Matrix3d::Identity();
  k(0, 0) = fx_;
  k(1, 1) = fy_;
  k(0, 2) = cx_;
  k(1, 2) = cy_;
  return k;
}

}  // namespace hisfm
