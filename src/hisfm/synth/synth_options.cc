#include "hisfm/synth/synth_options.h"

#include "hisfm/util/error.h"

namespace hisfm {

const std::vector<std::string>& SynthSceneNames() {
  static const std::vector<std::string> names = {
      "symmetric2",    "symmetric4", "object_control",   "street",
      "street_control", "facade_street", "block_loop", "crossing_streets",
      "symmetric_object"};
  return names;
}

SynthSceneType ParseSynthSceneType(const std::string& name) {
  const std::vector<std::string>& names = SynthSceneNames();
  for (size_t i = 0; i < names.size(); ++i) {
    if (names[i] == name) return static_cast<SynthSceneType>(i);
  }
  std::string valid;
  for (const std::string& n : names) valid += (valid.empty() ? "" : ", ") + n;
  throw Error(StrCat("unknown scene '", name, "' (valid: ", valid, ")"));
}

std::string SynthSceneTypeName(SynthSceneType type) {
  return SynthSceneNames().at(static_cast<size_t>(type));
}

bool IsSynthFamily(SynthSceneType type) {
  return static_cast<int>(type) >= static_cast<int>(SynthSceneType::kFacadeStreet);
}

SynthTwoViewMode ParseSynthTwoViewMode(const std::string& name) {
  if (name == "direct") return SynthTwoViewMode::kDirect;
  if (name == "colmap") return SynthTwoViewMode::kColmap;
  throw Error(StrCat("unknown --two_view_geometry '", name,
                     "' (valid: direct, colmap)"));
}

void SynthFamilyOptions::Check() const {
  HISFM_CHECK_OPTION(period, period >= 1 && period <= 20, "in [1, 20]");
  HISFM_CHECK_OPTION(camera_spacing,
                     camera_spacing >= 0.1 && camera_spacing <= 10,
                     "in [0.1, 10]");
  HISFM_CHECK_OPTION(facade_distance,
                     facade_distance >= 4 && facade_distance <= 40,
                     "in [4, 40]");
  HISFM_CHECK_OPTION(relief_depth,
                     relief_depth >= 0 && relief_depth <= 3, "in [0, 3]");
  HISFM_CHECK_OPTION(clutter_density,
                     clutter_density >= 0 && clutter_density <= 5, "in [0, 5]");
  HISFM_CHECK_OPTION(block_length, block_length == 0 || block_length >= period,
                     "0 or >= period");
  HISFM_CHECK_OPTION(ground_density,
                     ground_density >= 0 && ground_density <= 5, "in [0, 5]");
  HISFM_CHECK_OPTION(position_jitter,
                     position_jitter >= 0 && position_jitter <= 1, "in [0, 1]");
  HISFM_CHECK_OPTION(rotation_jitter,
                     rotation_jitter >= 0 && rotation_jitter <= 15,
                     "in [0, 15]");
  HISFM_CHECK_OPTION(block_aspect,
                     block_aspect >= 0.2 && block_aspect <= 1, "in [0.2, 1]");
  HISFM_CHECK_OPTION(view_angle,
                     view_angle >= 20 && view_angle <= 90, "in [20, 90]");
  HISFM_CHECK_OPTION(symmetry_order,
                     symmetry_order >= 2 && symmetry_order <= 8, "in [2, 8]");
  HISFM_CHECK_OPTION(ring_radius,
                     ring_radius >= 2 && ring_radius <= 10, "in [2, 10]");
  HISFM_CHECK_OPTION(descriptor_noise,
                     descriptor_noise >= 0 && descriptor_noise <= 20,
                     "in [0, 20]");
}

void SynthOptions::Check() const {
  ParseSynthSceneType(scene);
  ParseSynthTwoViewMode(two_view_geometry);
  HISFM_CHECK_OPTION(num_images, num_images >= 2, ">= 2");
  HISFM_CHECK_OPTION(num_images, num_images <= 1000000, "<= 1000000");
  HISFM_CHECK_OPTION(camera_model,
                     camera_model == "SIMPLE_PINHOLE" ||
                     camera_model == "PINHOLE" ||
                     camera_model == "SIMPLE_RADIAL",
                     "one of SIMPLE_PINHOLE, PINHOLE, SIMPLE_RADIAL");
  HISFM_CHECK_OPTION(image_width, image_width >= 64, ">= 64");
  HISFM_CHECK_OPTION(image_height, image_height >= 64, ">= 64");
  HISFM_CHECK_OPTION(focal_length, focal_length > 0, "> 0");
  HISFM_CHECK_OPTION(object_density,
                     object_density > 0 && object_density <= 100,
                     "in (0, 100]");
  HISFM_CHECK_OPTION(street_block_houses, street_block_houses >= 1, ">= 1");
  HISFM_CHECK_OPTION(background_density,
                     background_density >= 0 && background_density <= 100,
                     "in [0, 100]");
  HISFM_CHECK_OPTION(keypoint_noise,
                     keypoint_noise >= 0 && keypoint_noise < 10, "in [0, 10)");
  HISFM_CHECK_OPTION(detection_probability,
                     detection_probability > 0 && detection_probability <= 1,
                     "in (0, 1]");
  HISFM_CHECK_OPTION(distractor_ratio,
                     distractor_ratio >= 0 && distractor_ratio <= 10,
                     "in [0, 10]");
  HISFM_CHECK_OPTION(max_view_angle,
                     max_view_angle > 0 && max_view_angle < 180, "in (0, 180)");
  HISFM_CHECK_OPTION(max_scale_ratio, max_scale_ratio >= 1, ">= 1");
  HISFM_CHECK_OPTION(outlier_ratio,
                     outlier_ratio >= 0 && outlier_ratio <= 1, "in [0, 1]");
  HISFM_CHECK_OPTION(min_num_inliers, min_num_inliers >= 8, ">= 8");
  HISFM_CHECK_OPTION(max_error, max_error > 0, "> 0");
  HISFM_CHECK_OPTION(min_inlier_ratio,
                     min_inlier_ratio >= 0 && min_inlier_ratio <= 1,
                     "in [0, 1]");
  HISFM_CHECK_OPTION(colmap_path, !colmap_path.empty(), "non-empty");
  family.Check();
}

}  // namespace hisfm
