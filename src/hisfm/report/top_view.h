// Plane and 2D positions for the report's drawings: a top view of a model
// (seen from "above" as the cameras' mean up vector defines it, or the
// plane of the two principal directions of its camera centres), a circle
// layout of view-graph communities when there is no model, and the
// similarity that overlays a reference model on a reconstruction.
#pragma once

#include <Eigen/Core>
#include <map>
#include <string>
#include <vector>

#include "hisfm/eval/similarity_alignment.h"
#include "hisfm/io/model.h"

namespace hisfm {

/// An orthographic top view: 2D coordinates x = axis_x . (p - origin),
/// y = axis_y . (p - origin), with axis_x, axis_y orthonormal.
struct TopViewFrame {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d axis_x = Eigen::Vector3d::UnitX();
  Eigen::Vector3d axis_y = Eigen::Vector3d::UnitY();
  /// True if the view looks down the cameras' common up direction, false if
  /// the plane of the principal directions of the centres is used.
  bool along_up = false;

  /// The 2D coordinates of a world point.
  Eigen::Vector2d Project(const Eigen::Vector3d& p) const {
    const Eigen::Vector3d d = p - origin;
    return {axis_x.dot(d), axis_y.dot(d)};
  }
  /// The 2D direction of a world direction.
  Eigen::Vector2d ProjectDirection(const Eigen::Vector3d& d) const {
    return {axis_x.dot(d), axis_y.dot(d)};
  }
};

/// Cameras agree on "up" if the mean of their unit up vectors is at least
/// this long.
constexpr double kMinUpAgreement = 0.5;

/// The top view of a model, origin at the mean camera centre. If the
/// cameras agree on "up" (the mean of their -y axes, COLMAP cameras looking
/// along +z with +y down, has length >= kMinUpAgreement), the view looks
/// down that mean up direction and axis_x is the main direction of the
/// centres in the horizontal plane (a path of photos stays a path, and the
/// photographed side stays in view). Otherwise the plane is that of the two
/// largest principal directions of the centres (principal component
/// analysis), turned so that its normal axis_x x axis_y has a non-negative
/// component along the mean up; with fewer than three or collinear centres
/// the plane is completed from the mean up. An empty model gives the
/// identity frame.
TopViewFrame ComputeTopViewFrame(const Reconstruction& model);

/// Positions for drawing a view graph without a model: communities are
/// placed on a large circle (in increasing community id order), the images
/// of each on a small circle around its centre whose radius grows with the
/// square root of its size. Keys are image ids; `community_of` maps each
/// image to its community. Positions lie roughly within [-1, 1]^2.
std::map<uint32_t, Eigen::Vector2d> CommunityCircleLayout(
    const std::map<uint32_t, int>& community_of);

/// The similarity that maps `reference` camera centres onto `model` camera
/// centres (model_from_reference), estimated robustly (RANSAC over Umeyama
/// fits, hisfm/eval/similarity_alignment.h) on the images both models share
/// by name. Returns false with fewer than three common images or a failed
/// fit. `num_common` (optional) receives the number of common images.
bool AlignReferenceToModel(const Reconstruction& model,
                           const Reconstruction& reference, Sim3d* model_from_reference,
                           size_t* num_common = nullptr);

}  // namespace hisfm
