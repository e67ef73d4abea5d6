#include "hisfm/verify/triangulation.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>

namespace hisfm {

bool RayDepths(const Eigen::Matrix3d& R, const Eigen::Vector3d& t,
               const Eigen::Vector2d& x1, const Eigen::Vector2d& x2,
               double* depth1, double* depth2) {
  const Eigen::Vector3d a = R * x1.homogeneous();
  const Eigen::Vector3d b = x2.homogeneous();
  const double aa = a.squaredNorm(), ab = a.dot(b), bb = b.squaredNorm();
  const double at = a.dot(t), bt = b.dot(t);
  const double det = aa * bb - ab * ab;
  if (!(std::abs(det) > 1e-12 * aa * bb)) return false;
  *depth1 = (ab * bt - bb * at) / det;
  *depth2 = (aa * bt - ab * at) / det;
  return true;
}

Eigen::Vector3d TriangulateMultiView(const Rigid3d* cam_from_world,
                                     const Eigen::Vector2d* x, int num_views) {
  Eigen::Matrix3d AtA = Eigen::Matrix3d::Zero();
  Eigen::Vector3d Atb = Eigen::Vector3d::Zero();
  for (int v = 0; v < num_views; ++v) {
    const Eigen::Matrix3d R = cam_from_world[v].rotation.toRotationMatrix();
    const Eigen::Vector3d& t = cam_from_world[v].translation;
    for (int r = 0; r < 2; ++r) {
      // Row of the DLT system: x_r * P_2 - P_r, split into its 3x3 part and
      // its last column.
      const Eigen::Vector3d a = x[v](r) * R.row(2) - R.row(r);
      const double c = x[v](r) * t(2) - t(r);
      AtA += a * a.transpose();
      Atb -= a * c;
    }
  }
  // A rank-deficient system (fewer than two distinct rays) has a zero
  // pivot up to rounding: reject pivots tiny against the largest.
  const Eigen::LDLT<Eigen::Matrix3d> ldlt(AtA);
  const Eigen::Vector3d pivots = ldlt.vectorD();
  if (ldlt.info() != Eigen::Success || !ldlt.isPositive() ||
      !(pivots.minCoeff() > 1e-12 * pivots.maxCoeff())) {
    return Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  }
  return ldlt.solve(Atb);
}

double TriangulationAngle(const Eigen::Vector3d& center1,
                          const Eigen::Vector3d& center2,
                          const Eigen::Vector3d& point) {
  const Eigen::Vector3d r1 = point - center1;
  const Eigen::Vector3d r2 = point - center2;
  const double n = r1.norm() * r2.norm();
  if (n <= 0) return 0.0;
  return std::acos(std::clamp(r1.dot(r2) / n, -1.0, 1.0));
}

}  // namespace hisfm
