// Options of the synthetic scene generator (`hisfm synth`).
//
// The generator builds scenes with doppelgangers: repeated or symmetric
// structure that makes feature matches between images of *different* parts of
// a scene geometrically consistent, the failure mode studied by Yan et al.,
// "Distinguishing the Indistinguishable: Exploring Structural Ambiguities via
// Geodesic Context", CVPR 2017, and Cai et al., "Doppelgangers: Learning to
// Disambiguate Images of Similar Structures", ICCV 2023.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

namespace hisfm {

/// The scenes `hisfm synth` can generate.
enum class SynthSceneType {
  /// A cylinder-shaped object whose print repeats twice around it (2-fold
  /// rotational symmetry, like a mug with the same print on both sides), seen
  /// from a ring of cameras, on a unique ground and surrounding wall.
  kSymmetric2,
  /// The same with a 4-fold symmetric print.
  kSymmetric4,
  /// The geometry of kSymmetric2 with a unique print everywhere.
  kObjectControl,
  /// A street of facades whose pattern repeats with a period of one house
  /// along x, seen from a line of sideways-looking cameras moving along the
  /// street, with a few unique facade details and a unique ground.
  kStreet,
  /// The geometry of kStreet with every facade unique.
  kStreetControl,
};

/// Scene names as accepted by --scene, in enum order.
const std::vector<std::string>& SynthSceneNames();
/// Parses a --scene value; throws hisfm::Error listing the valid names.
SynthSceneType ParseSynthSceneType(const std::string& name);
/// The --scene name of a scene type.
std::string SynthSceneTypeName(SynthSceneType type);

/// How two_view_geometries are obtained.
enum class SynthTwoViewMode {
  /// Computed from the ground truth: for every pair, the larger group of
  /// matches consistent with one epipolar geometry (the true one or a
  /// doppelganger one) is kept, as RANSAC would.
  kDirect,
  /// Raw matches are written to a text file and verified by
  /// `colmap matches_importer --match_type raw`.
  kColmap,
};

/// Parses "direct" or "colmap"; throws hisfm::Error otherwise.
SynthTwoViewMode ParseSynthTwoViewMode(const std::string& name);

/// Options of the generator. Distances are in metres, angles in degrees.
struct SynthOptions {
  /// Scene name, see SynthSceneNames().
  std::string scene = "symmetric2";
  /// Number of images (at least 2).
  int num_images = 40;
  /// Seed of every random choice; the output is a function of the options.
  uint32_t seed = 0;

  /// Camera model of the single shared camera: SIMPLE_PINHOLE, PINHOLE or
  /// SIMPLE_RADIAL (radial distortion 0).
  std::string camera_model = "SIMPLE_RADIAL";
  /// Image size in pixels.
  int image_width = 1024;
  int image_height = 768;
  /// Focal length in pixels (principal point at the image centre).
  double focal_length = 800.0;

  /// Multiplier of the number of points on the object or facades (the
  /// repeated content of the ambiguous scenes).
  double object_density = 1.0;
  /// Street scenes: number of consecutive houses sharing one facade pattern
  /// (each block of houses has its own pattern). Longer blocks make more
  /// doppelganger pairs per image.
  int street_block_houses = 12;
  /// Multiplier of the number of points on the unique background (ground,
  /// wall, unique facade details).
  double background_density = 1.0;

  /// Standard deviation of the keypoint noise in pixels.
  double keypoint_noise = 0.7;
  /// Probability that a visible point is detected as a keypoint in an image.
  double detection_probability = 0.9;
  /// Extra keypoints without a 3D point, as a fraction of the detected ones.
  double distractor_ratio = 0.1;
  /// Two observations of same-looking points match only if their viewing
  /// rays, expressed in the local frame of the surface, differ by less than
  /// this angle (SIFT's viewpoint tolerance).
  double max_view_angle = 40.0;
  /// ... and if their distances to the cameras differ by less than this
  /// factor (SIFT's scale tolerance).
  double max_scale_ratio = 2.5;
  /// Random wrong matches added to every matched pair, as a fraction of its
  /// correct-appearance matches.
  double outlier_ratio = 0.03;

  /// "direct" or "colmap", see SynthTwoViewMode.
  std::string two_view_geometry = "direct";
  /// Verified pairs with fewer inliers are not written (COLMAP's
  /// --SiftMatching.min_num_inliers).
  int min_num_inliers = 15;
  /// Sampson error threshold of an inlier in pixels (COLMAP's
  /// --SiftMatching.max_error).
  double max_error = 4.0;
  /// A pair is verified only if this fraction of its matches are inliers
  /// (COLMAP's --SiftMatching.min_inlier_ratio).
  double min_inlier_ratio = 0.25;
  /// Also write the raw (putative) matches into the `matches` table (direct
  /// mode; the colmap mode always writes them through COLMAP).
  bool write_matches = true;
  /// Worker threads; <= 0 uses every core.
  int num_threads = -1;
  /// The COLMAP executable used by the colmap mode.
  std::string colmap_path = "colmap";

  /// Throws hisfm::Error naming the first invalid option.
  void Check() const;
};

}  // namespace hisfm
