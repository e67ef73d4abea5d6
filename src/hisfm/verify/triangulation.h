// Triangulation of correspondences between calibrated views.
//
// Linear (DLT) triangulation, Hartley & Zisserman, "Multiple View Geometry
// in Computer Vision", 2nd ed., Sec. 12.2, solved here for finite points
// only (last homogeneous coordinate fixed to 1) through the 3x3 normal
// equations; and the depths of two rays' closest points, whose signs decide
// cheirality (Sec. 9.6.3) without a full triangulation.
#pragma once

#include <Eigen/Core>

#include "hisfm/util/rigid3d.h"

namespace hisfm {

/// Depths along two rays at their points of closest approach, for camera 1
/// at the origin and camera 2 = cam2_from_cam1, from normalized image
/// points: d1 * R x1 + t ~ d2 x2 in the least-squares sense. Returns false
/// (and leaves the depths untouched) when the rays are parallel.
bool RayDepths(const Eigen::Matrix3d& R, const Eigen::Vector3d& t,
               const Eigen::Vector2d& x1, const Eigen::Vector2d& x2,
               double* depth1, double* depth2);

/// Linear triangulation from `num_views` views: `cam_from_world[v]` maps
/// world points into view v, `x[v]` is the normalized image point there.
/// Returns NaNs if the system is degenerate.
Eigen::Vector3d TriangulateMultiView(const Rigid3d* cam_from_world,
                                     const Eigen::Vector2d* x, int num_views);

/// Angle (radians) at `point` between the rays to the two camera centres.
double TriangulationAngle(const Eigen::Vector3d& center1,
                          const Eigen::Vector3d& center2,
                          const Eigen::Vector3d& point);

}  // namespace hisfm
