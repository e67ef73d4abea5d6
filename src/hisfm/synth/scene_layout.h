// The 3D content of a synthetic scene: textured points with appearance ids,
// camera poses, the scene's symmetry and its occluders.
//
// Every point carries an appearance id: two points with the same id look
// alike to a feature matcher. Repeated content (the faces of a symmetric
// object, the houses of a street) shares appearance ids between its copies
// ("replicas"), so that a matcher pairs a feature with a copy of its true
// point; the copies are related by the scene's symmetry, which makes such
// doppelganger matches consistent with one wrong epipolar geometry.
//
// Scenes (z is up, metres):
//  - symmetric2 / symmetric4 / object_control: a cylinder of radius 1 and
//    height 1.6 on the ground, its print repeated 2 or 4 times around the
//    axis (object_control: the 2-fold geometry with a unique print), seen by a
//    ring of cameras at radius ~4 and height ~1.4 looking at it; a unique
//    ground disc and a unique surrounding wall (radius 8, height 4).
//  - street / street_control: facades in the plane y = 8 (with relief),
//    0 to 8 m high, whose pattern repeats every house (4 m) within blocks of
//    SynthOptions::street_block_houses houses (default 12; each block has its
//    own pattern; street_control: every house unique), a few unique facade details and a unique ground; cameras at
//    y ~ 0 every 0.8 m along x, 1.6 m high, looking at the facades.
//  - the families facade_street, block_loop, crossing_streets and
//    symmetric_object: see hisfm/synth/scene_families.h.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "hisfm/synth/synth_options.h"
#include "hisfm/util/rigid3d.h"

namespace hisfm {

/// The symmetry that relates the replicas of repeated content. Element k maps
/// a point of replica r onto the same-looking point of replica r + k.
struct SymmetryGroup {
  enum class Type {
    kNone,          ///< No repeated content.
    kRotationZ,     ///< Rotations by 2 pi k / order about the z axis.
    kTranslationX,  ///< Translations by k * period along x, |k| <= max_shift.
    /// Each replica r is a rigid copy of a motif placed by
    /// replica_frames[r] (world_from_motif); element k is the k-th distinct
    /// transform world_from_motif(q) * world_from_motif(p)^-1 between two
    /// replicas of the same motif (0 = identity).
    kReplicaFrames,
  };
  Type type = Type::kNone;
  int order = 1;
  double period = 0.0;
  int max_shift = 0;
  /// kReplicaFrames: the pose of every replica, its motif, the distinct
  /// relations (relations[0] is the identity) and, for replicas p and q of
  /// one motif, relation_table[p * replica_frames.size() + q] = the index
  /// of their relation (-1 for replicas of different motifs).
  std::vector<Rigid3d> replica_frames;
  std::vector<int> replica_motifs;
  std::vector<Rigid3d> relations;
  std::vector<int32_t> relation_table;

  /// All elements, the identity (0) first.
  std::vector<int> Elements() const;
  /// The world transform of element k.
  Rigid3d Transform(int k) const;
  /// The element k with replica_q = replica_p + k.
  int Relation(int replica_p, int replica_q) const;
};

/// A textured surface point.
struct ScenePoint {
  Eigen::Vector3d xyz = Eigen::Vector3d::Zero();
  /// Outward unit normal of the surface.
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  /// A unit tangent; with the normal it fixes the local frame in which
  /// viewing directions are compared (it follows the symmetry).
  Eigen::Vector3d tangent = Eigen::Vector3d::UnitX();
  /// Points with equal ids look alike to the matcher.
  uint32_t appearance = 0;
  /// Index of the copy of repeated content the point belongs to (0 for
  /// unique content).
  int32_t replica = 0;
  /// True for points of the object or facades (false: background).
  bool on_object = false;
  /// True for points of the clutter objects of the street families.
  bool clutter = false;
};

/// A solid vertical cylinder that hides what lies behind it.
struct CylinderOccluder {
  Eigen::Vector2d center = Eigen::Vector2d::Zero();
  double radius = 1.0;
  double z_min = 0.0;
  double z_max = 1.0;

  /// True if the open segment from a to b passes through the cylinder.
  bool Occludes(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const;
};

/// A solid box standing on the ground (a parked car, a kiosk), rotated by
/// `yaw` about the vertical axis, that hides what lies behind it.
struct BoxOccluder {
  Eigen::Vector2d center = Eigen::Vector2d::Zero();
  /// Half extents along the box's own x and y axes.
  Eigen::Vector2d half_size = Eigen::Vector2d::Ones();
  /// Rotation of the box's x axis from the world's x axis (radians).
  double yaw = 0.0;
  double z_min = 0.0;
  double z_max = 1.0;

  /// True if the open segment from a to b passes through the box.
  bool Occludes(const Eigen::Vector3d& a, const Eigen::Vector3d& b) const;
};

/// The 3D content and cameras of a scene.
struct SceneLayout {
  SynthSceneType type = SynthSceneType::kSymmetric2;
  std::vector<ScenePoint> points;
  /// Pose of each image, in image order.
  std::vector<Rigid3d> cams_from_world;
  SymmetryGroup symmetry;
  /// Solids hiding background points (points on an occluder's own surface
  /// are culled by their normals instead).
  std::vector<CylinderOccluder> occluders;
  /// Two images can match only if, for some symmetry element k, the centre of
  /// one and the k-transformed centre of the other are closer than this.
  double pair_radius = 1.0;
  /// Points farther than this from a camera are not seen.
  double max_view_distance = 1.0;
  /// Family scenes (IsSynthFamily): every point, repeated or not, may be
  /// hidden by the occluders (cylinders and boxes), keypoints carry
  /// descriptor noise, candidate pairs are the pairs of images that see a
  /// common appearance, and verification imitates COLMAP's choice between
  /// an essential and a fundamental matrix (synthetic_matches.h).
  bool family = false;
  /// If positive, a point at distance d seen at angle a from its normal is
  /// detected with probability detection_probability * min(1,
  /// detection_reference_distance^2 * cos(a) / d^2): the image density of
  /// keypoints is capped at the one of a surface seen head-on from this
  /// distance, as a detector of fixed resolution misses texture that is too
  /// fine (family streets: facade_distance).
  double detection_reference_distance = 0.0;
  /// Family scenes: the parameters used, drawn ones included.
  SynthFamilyOptions family_options;
  std::vector<BoxOccluder> boxes;
};

/// Builds the points and cameras of options.scene (deterministic in
/// options.seed). Throws hisfm::Error on invalid options.
SceneLayout BuildSceneLayout(const SynthOptions& options);

/// A camera at `center` looking at `target`, with the image's y axis pointing
/// down (towards -z); roll_deg rotates about the viewing direction.
Rigid3d LookAt(const Eigen::Vector3d& center, const Eigen::Vector3d& target,
               double roll_deg = 0.0);

}  // namespace hisfm
