// Relative pose of an image pair recovered from its stored two-view geometry.
//
// COLMAP 3.8 stores E (and F, H) in two_view_geometries but, for databases
// written by the matcher, leaves qvec/tvec zero. The pose is recovered the
// textbook way (Hartley & Zisserman, "Multiple View Geometry", 2nd ed.,
// Sec. 9.6.2): E = U diag(1,1,0) V^T gives R in {U W V^T, U W^T V^T} and
// t = +-u3; the candidate with the most inliers triangulating in front of
// both cameras (cheirality) wins. For uncalibrated pairs (config 3) the
// essential matrix is E = K2^T F K1.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "hisfm/io/database.h"
#include "hisfm/util/rigid3d.h"

namespace hisfm {

/// Linear (DLT) triangulation of one correspondence between camera 1 at the
/// origin and camera 2 = cam2_from_cam1, from normalized image points.
/// Returns the point in camera-1 coordinates.
Eigen::Vector3d TriangulatePoint(const Rigid3d& cam2_from_cam1,
                                 const Eigen::Vector2d& x1,
                                 const Eigen::Vector2d& x2);

/// Decomposes `E` (x2^T E x1 = 0 on normalized points) and picks the
/// candidate pose with most correspondences in front of both cameras (depths
/// of the rays' closest points, by 2x2 normal equations; correspondences
/// with parallel rays do not vote).
/// Writes the unit-baseline pose and returns the number of correspondences
/// in front; returns 0 (and leaves the pose untouched) if E is degenerate or
/// no correspondence is given.
int PoseFromEssential(const Eigen::Matrix3d& E,
                      const std::vector<Eigen::Vector2d>& x1,
                      const std::vector<Eigen::Vector2d>& x2,
                      Rigid3d* cam2_from_cam1);

/// The essential matrix of a stored geometry, oriented as stored (image_id1
/// of the pair is camera 1): the stored E for calibrated (2) and
/// planar/panoramic (4, 5, 6) pairs when it is non-zero, else K2^T F K1.
/// Returns zero if the geometry holds neither.
Eigen::Matrix3d EssentialOfGeometry(const TwoViewGeometry& geometry,
                                    const Eigen::Matrix3d& K1,
                                    const Eigen::Matrix3d& K2);

}  // namespace hisfm
