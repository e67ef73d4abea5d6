#include "hisfm/verify/two_view_pose.h"

#include <Eigen/Dense>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>

namespace hisfm {

Eigen::Vector3d TriangulatePoint(const Rigid3d& cam2_from_cam1,
                                 const Eigen::Vector2d& x1,
                                 const Eigen::Vector2d& x2) {
  Eigen::Matrix<double, 3, 4> P1 = Eigen::Matrix<double, 3, 4>::Zero();
  P1.leftCols<3>().setIdentity();
  Eigen::Matrix<double, 3, 4> P2;
  P2.leftCols<3>() = cam2_from_cam1.rotation.toRotationMatrix();
  P2.col(3) = cam2_from_cam1.translation;
  Eigen::Matrix4d A;
  A.row(0) = x1.x() * P1.row(2) - P1.row(0);
  A.row(1) = x1.y() * P1.row(2) - P1.row(1);
  A.row(2) = x2.x() * P2.row(2) - P2.row(0);
  A.row(3) = x2.y() * P2.row(2) - P2.row(1);
  const Eigen::JacobiSVD<Eigen::Matrix4d> svd(A, Eigen::ComputeFullV);
  const Eigen::Vector4d X = svd.matrixV().col(3);
  if (std::abs(X(3)) < 1e-12) {
    return Eigen::Vector3d::Constant(std::numeric_limits<double>::quiet_NaN());
  }
  return X.head<3>() / X(3);
}

int PoseFromEssential(const Eigen::Matrix3d& E,
                      const std::vector<Eigen::Vector2d>& x1,
                      const std::vector<Eigen::Vector2d>& x2,
                      Rigid3d* cam2_from_cam1) {
  if (x1.empty() || x1.size() != x2.size() || E.norm() < 1e-12) return 0;
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(
      E, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d U = svd.matrixU();
  Eigen::Matrix3d V = svd.matrixV();
  if (U.determinant() < 0) U *= -1;
  if (V.determinant() < 0) V *= -1;
  Eigen::Matrix3d W;
  W << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  const Eigen::Matrix3d Ra = U * W * V.transpose();
  const Eigen::Matrix3d Rb = U * W.transpose() * V.transpose();
  const Eigen::Vector3d t = U.col(2).normalized();
  const Eigen::Matrix3d rotations[4] = {Ra, Ra, Rb, Rb};
  const Eigen::Vector3d translations[4] = {t, -t, t, -t};
  int best = 0;
  int best_count = -1;
  for (int c = 0; c < 4; ++c) {
    const Eigen::Matrix3d& R = rotations[c];
    const Eigen::Vector3d& tc = translations[c];
    int count = 0;
    for (size_t k = 0; k < x1.size(); ++k) {
      // Depths d1, d2 with d1 R h1 + t ~ d2 h2 in the least-squares sense
      // (the two rays' closest points): cheirality needs only their signs,
      // which the 2x2 normal equations give without an SVD.
      const Eigen::Vector3d a = R * x1[k].homogeneous();
      const Eigen::Vector3d b = x2[k].homogeneous();
      const double aa = a.squaredNorm(), ab = a.dot(b), bb = b.squaredNorm();
      const double at = a.dot(tc), bt = b.dot(tc);
      const double det = aa * bb - ab * ab;
      if (!(std::abs(det) > 1e-12 * aa * bb)) continue;  // Parallel rays.
      const double d1 = (ab * bt - bb * at) / det;
      const double d2 = (aa * bt - ab * at) / det;
      if (d1 > 0 && d2 > 0) ++count;
    }
    if (count > best_count) {
      best_count = count;
      best = c;
    }
  }
  if (best_count <= 0) return 0;
  *cam2_from_cam1 = Rigid3d(Eigen::Quaterniond(rotations[best]).normalized(),
                            translations[best]);
  return best_count;
}

Eigen::Matrix3d EssentialOfGeometry(const TwoViewGeometry& geometry,
                                    const Eigen::Matrix3d& K1,
                                    const Eigen::Matrix3d& K2) {
  const bool calibrated_like =
      geometry.config == static_cast<int>(TwoViewConfig::kCalibrated) ||
      geometry.config == static_cast<int>(TwoViewConfig::kPlanar) ||
      geometry.config == static_cast<int>(TwoViewConfig::kPanoramic) ||
      geometry.config == static_cast<int>(TwoViewConfig::kPlanarOrPanoramic);
  if (calibrated_like && geometry.E.norm() > 1e-12) return geometry.E;
  if (geometry.F.norm() > 1e-12) return K2.transpose() * geometry.F * K1;
  if (geometry.E.norm() > 1e-12) return geometry.E;
  return Eigen::Matrix3d::Zero();
}

}  // namespace hisfm
