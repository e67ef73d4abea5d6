// Images of a synthetic scene: which points each camera sees, their noisy
// keypoints, and the ground-truth model.
//
// A point is seen by a camera if it projects into the image, lies in front of
// it and closer than the scene's view distance, faces the camera (angle
// between its normal and the viewing ray below 80 degrees) and no occluder
// lies between them; it is then detected with probability
// SynthOptions::detection_probability, at its projection plus Gaussian noise.
// Distractor keypoints (no 3D point) are added, and the keypoints of an image
// are shuffled. Image i (0-based) has image id i + 1 and the name
// SynthImageName(i) = "%06d.png". In family scenes (SceneLayout::family) the
// occluders hide every kind of point (a point's own surface excepted), and
// each keypoint's local viewing ray gets Gaussian noise of
// SynthFamilyOptions::descriptor_noise per axis before it is renormalised.
#pragma once

#include <Eigen/Core>
#include <limits>
#include <string>
#include <utility>
#include <vector>

#include "hisfm/io/database.h"
#include "hisfm/io/model.h"
#include "hisfm/synth/scene_layout.h"
#include "hisfm/synth/synth_options.h"

namespace hisfm {

/// point_index of a keypoint that observes no scene point.
constexpr uint32_t kNoScenePoint = std::numeric_limits<uint32_t>::max();

/// One keypoint of a synthetic image.
struct SynthFeature {
  /// Index into SceneLayout::points, or kNoScenePoint for a distractor.
  uint32_t point_index = kNoScenePoint;
  /// Keypoint position in pixels (COLMAP convention), noise included.
  Eigen::Vector2f xy = Eigen::Vector2f::Zero();
  /// Unit ray from the point to the camera in the point's local frame
  /// (tangent, normal x tangent, normal): the matcher's descriptor proxy.
  Eigen::Vector3f local_view = Eigen::Vector3f::Zero();
  /// Distance from the camera centre to the point (scale proxy).
  float distance = 0.0f;
};

/// One synthetic image.
struct SynthImage {
  ImageId image_id = kInvalidImageId;
  std::string name;
  Rigid3d cam_from_world;
  /// Keypoints in database order.
  std::vector<SynthFeature> features;
  /// (appearance id, feature index) of every feature with a point, sorted.
  std::vector<std::pair<uint32_t, uint32_t>> appearance_index;

  /// Keypoint locations as written to the database.
  Keypoints KeypointMatrix() const;
};

/// A generated scene: layout, the shared camera and the images.
struct SyntheticScene {
  SynthOptions options;
  SceneLayout layout;
  /// The single camera (camera id 1) with its COLMAP parameters.
  Camera camera;
  /// Calibration matrix of the camera.
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();
  /// images[i].image_id == i + 1.
  std::vector<SynthImage> images;

  /// Total number of keypoints over all images.
  size_t NumKeypoints() const;
};

/// Name of image `index` (0-based): "000000.png", "000001.png", ...
std::string SynthImageName(size_t index);

/// Builds the layout of options.scene and the keypoints of every image.
/// Deterministic in the options (any number of threads). Throws
/// hisfm::Error on invalid options.
SyntheticScene GenerateScene(const SynthOptions& options);

/// The ground truth as a COLMAP model: the camera, every image with its true
/// pose and all its keypoints, and every point observed by at least two
/// images (point3D_id = point index + 1) with its track; keypoints of points
/// seen once and distractors have no 3D point.
Reconstruction BuildGroundTruthModel(const SyntheticScene& scene);

/// Projects a world point with a pose and calibration (no distortion).
Eigen::Vector2d ProjectPoint(const Eigen::Matrix3d& K,
                             const Rigid3d& cam_from_world,
                             const Eigen::Vector3d& xyz);

}  // namespace hisfm
