// A rigid transform b_from_a: x_b = rotation * x_a + translation.
// Named like COLMAP's Rigid3d (cam_from_world maps world points into the
// camera frame).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>

namespace hisfm {

/// Rigid transform x_b = rotation * x_a + translation ("b_from_a").
struct Rigid3d {
  Eigen::Quaterniond rotation = Eigen::Quaterniond::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();

  Rigid3d() = default;
  Rigid3d(const Eigen::Quaterniond& q, const Eigen::Vector3d& t)
      : rotation(q), translation(t) {}

  /// Applies the transform to a point.
  Eigen::Vector3d operator*(const Eigen::Vector3d& x) const {
    return rotation * x + translation;
  }
  /// Composition: (c_from_b * b_from_a) = c_from_a.
  Rigid3d operator*(const Rigid3d& b_from_a) const {
    return Rigid3d(rotation * b_from_a.rotation,
                   rotation * b_from_a.translation + translation);
  }
  /// a_from_b.
  Rigid3d Inverse() const {
    const Eigen::Quaterniond inv = rotation.inverse();
    return Rigid3d(inv, -(inv * translation));
  }
};

}  // namespace hisfm
