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
  /// Family: a straight pass along one long facade whose pattern repeats
  /// with SynthFamilyOptions::period, cameras looking at it, unique clutter
  /// between the cameras and the facade (hisfm/synth/scene_families.h).
  kFacadeStreet,
  /// Family: a closed loop of cameras around a rectangular city block whose
  /// four facades and corners carry the same repeated pattern.
  kBlockLoop,
  /// Family: two perpendicular streets crossing, repeated facades on both
  /// sides of both, cameras along both streets looking sideways-ahead.
  kCrossingStreets,
  /// Family: the cylinder object with an n-fold print
  /// (SynthFamilyOptions::symmetry_order) seen from a ring of cameras, with
  /// a unique background of variable density.
  kSymmetricObject,
};

/// Scene names as accepted by --scene, in enum order.
const std::vector<std::string>& SynthSceneNames();
/// Parses a --scene value; throws hisfm::Error listing the valid names.
SynthSceneType ParseSynthSceneType(const std::string& name);
/// The --scene name of a scene type.
std::string SynthSceneTypeName(SynthSceneType type);
/// True for the parametric families (kFacadeStreet and later), false for
/// the five fixed scenes.
bool IsSynthFamily(SynthSceneType type);

/// How two_view_geometries are obtained.
enum class SynthTwoViewMode {
  /// Computed from the ground truth: for every pair, the epipolar geometry
  /// (the true one or a doppelganger one) with the most matches within
  /// max_error is kept with all those matches, as RANSAC would; family
  /// scenes also imitate COLMAP's choice between essential, fundamental and
  /// homography matrices (hisfm/synth/synthetic_matches.h).
  kDirect,
  /// Raw matches are written to a text file and verified by
  /// `colmap matches_importer --match_type raw`.
  kColmap,
};

/// Parses "direct" or "colmap"; throws hisfm::Error otherwise.
SynthTwoViewMode ParseSynthTwoViewMode(const std::string& name);

/// Parameters of the scene families (IsSynthFamily); the fixed scenes ignore
/// them. Distances are in metres, angles in degrees. With `randomize`, the
/// parameters marked "random" are drawn from the given ranges using
/// SynthOptions::seed (the drawn values are written into synth_summary.json),
/// so that (family, num_images, seed) defines an instance.
struct SynthFamilyOptions {
  /// Draw the parameters marked "random" instead of using their values.
  bool randomize = false;
  /// Streets: period of the facade pattern along the facades (random: 2 to
  /// 8).
  double period = 4.0;
  /// Streets: distance between consecutive camera positions along the path
  /// (random: 0.5 to 2 with period / camera_spacing in [2, 10]). block_loop:
  /// the loop is num_images * camera_spacing long, or longer when the block
  /// needs it (each side is at least one period), the spacing then grows.
  double camera_spacing = 1.0;
  /// Streets: distance from the camera path to the facade plane (random: 5
  /// to 15). The facade's point density falls as 1 / facade_distance^2, so
  /// that images see about the same number of facade points.
  double facade_distance = 6.0;
  /// Streets: depth of the facade relief, 0 = planar (random: 0 to 1.5).
  /// Balconies protrude by relief_depth, pillars by half of it, windows are
  /// recessed by 0.3 of it; their side faces carry points too.
  double relief_depth = 0.0;
  /// Unique clutter points per repeated point (facade or object points) in
  /// the scene (random: 0.1 to 0.5). Streets: poles, trees, parked cars and
  /// kiosks between the cameras and the facades, which they partly hide;
  /// symmetric_object: the surrounding wall and ground.
  double clutter_density = 0.33;
  /// Streets: metres of facade that share one pattern, rounded to whole
  /// periods; 0 = one pattern for all facades.
  double block_length = 0.0;
  /// Streets: unique ground points per facade point; 0 = no ground.
  double ground_density = 0.0;
  /// Every copy of the pattern is different: the family's control scene,
  /// without repeated structure.
  bool unique_pattern = false;
  /// Standard deviation of the camera position noise (random: 0 to 0.2).
  double position_jitter = 0.1;
  /// Standard deviation of the camera yaw and pitch noise (roll: half of
  /// it) (random: 0 to 4).
  double rotation_jitter = 2.0;
  /// block_loop: short side / long side of the block (random: 0.5 to 1).
  double block_aspect = 1.0;
  /// crossing_streets: angle between the viewing direction and the street
  /// ahead, 90 = sideways (random: 40 to 60). Images alternate between the
  /// left and the right side of the street.
  double view_angle = 45.0;
  /// symmetric_object: the print repeats this many times around the object
  /// (random: 2, 3 or 4).
  int symmetry_order = 3;
  /// symmetric_object: radius of the camera ring around the object's axis
  /// (random: 3 to 6).
  double ring_radius = 4.0;
  /// Standard deviation (degrees) of the noise on each keypoint's local
  /// viewing ray, the matcher's descriptor proxy: among copies of a pattern
  /// seen under similar angles, which one a feature matches is partly
  /// random, as with real descriptors.
  double descriptor_noise = 3.0;

  /// Throws hisfm::Error naming the first invalid option.
  void Check() const;
};

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
  /// repeated content of the ambiguous scenes, families included).
  double object_density = 1.0;
  /// Street scenes: number of consecutive houses sharing one facade pattern
  /// (each block of houses has its own pattern). Longer blocks make more
  /// doppelganger pairs per image.
  int street_block_houses = 12;
  /// Multiplier of the number of points on the unique background (ground,
  /// wall, unique facade details) of the fixed scenes (families:
  /// SynthFamilyOptions::clutter_density and ground_density).
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
  /// Parameters of the scene families.
  SynthFamilyOptions family;

  /// Throws hisfm::Error naming the first invalid option.
  void Check() const;
};

}  // namespace hisfm
