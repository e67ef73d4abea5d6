// Pixel <-> normalized camera coordinates for the COLMAP camera models that
// the database readers meet (the parameter orders are COLMAP 3.8's,
// src/base/camera_models.h):
//   0 SIMPLE_PINHOLE  f, cx, cy
//   1 PINHOLE         fx, fy, cx, cy
//   2 SIMPLE_RADIAL   f, cx, cy, k
//   3 RADIAL          f, cx, cy, k1, k2
//   4 OPENCV          fx, fy, cx, cy, k1, k2, p1, p2
// Pixel coordinates follow COLMAP: the centre of the upper-left pixel is
// (0.5, 0.5).
#pragma once

#include <Eigen/Core>
#include <vector>

#include "hisfm/io/database.h"

namespace hisfm {

/// A camera's intrinsics in a form that projects and unprojects quickly.
class CameraProjection {
 public:
  CameraProjection() = default;
  /// Throws hisfm::Error if the model is not one of the five above or the
  /// parameter count is wrong.
  explicit CameraProjection(const DatabaseCamera& camera);
  CameraProjection(int model_id, uint64_t width, uint64_t height,
                   const std::vector<double>& params);

  /// True if `model_id` is one of the supported models.
  static bool IsSupportedModel(int model_id);

  /// Normalized image-plane point (x/z, y/z) -> pixel, with distortion.
  Eigen::Vector2d NormalizedToPixel(const Eigen::Vector2d& xy) const;
  /// Pixel -> normalized image-plane point, undistorting iteratively.
  Eigen::Vector2d PixelToNormalized(const Eigen::Vector2d& uv) const;
  /// The pinhole calibration matrix (distortion ignored).
  Eigen::Matrix3d K() const;
  /// Mean focal length in pixels.
  double MeanFocal() const { return 0.5 * (fx_ + fy_); }
  uint64_t width() const { return width_; }
  uint64_t height() const { return height_; }
  /// True if the pixel lies inside the image, `margin` pixels from its border.
  bool InImage(const Eigen::Vector2d& uv, double margin = 0.0) const {
    return uv.x() >= margin && uv.y() >= margin &&
           uv.x() <= static_cast<double>(width_) - margin &&
           uv.y() <= static_cast<double>(height_) - margin;
  }

 private:
  Eigen::Vector2d Distort(const Eigen::Vector2d& xy) const;

  uint64_t width_ = 0;
  uint64_t height_ = 0;
  double fx_ = 1, fy_ = 1, cx_ = 0, cy_ = 0;
  double k1_ = 0, k2_ = 0, p1_ = 0, p2_ = 0;
};

}  // namespace hisfm
