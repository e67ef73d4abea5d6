#include "hisfm/synth/synth_options.h"

#include "hisfm/util/error.h"

namespace hisfm {

const std::vector<std::string>& SynthSceneNames() {
  static const std::vector<std::string> names = {
      "symmetric2", "symmetric4", "object_control", "street",
      "street_control"};
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

SynthTwoViewMode ParseSynthTwoViewMode(const std::string& name) {
  if (name == "direct") return SynthTwoViewMode::kDirect;
  if (name == "colmap") return SynthTwoViewMode::kColmap;
  throw Error(StrCat("unknown --two_view_geometry '", name,
                     "' (valid: direct, colmap)"));
}

void SynthOptions::Check() const {
  ParseSynthSceneType(scene);
  ParseSynthTwoViewMode(two_view_geometry);
  HISFM_CHECK_OPTION(num_images >= 2);
  HISFM_CHECK_OPTION(num_images <= 1000000);
  HISFM_CHECK_OPTION(camera_model == "SIMPLE_PINHOLE" ||
                     camera_model == "PINHOLE" ||
                     camera_model == "SIMPLE_RADIAL");
  HISFM_CHECK_OPTION(image_width >= 64 && image_height >= 64);
  HISFM_CHECK_OPTION(focal_length > 0);
  HISFM_CHECK_OPTION(object_density > 0 && object_density <= 100);
  HISFM_CHECK_OPTION(street_block_houses >= 1);
  HISFM_CHECK_OPTION(background_density >= 0 && background_density <= 100);
  HISFM_CHECK_OPTION(keypoint_noise >= 0 && keypoint_noise < 10);
  HISFM_CHECK_OPTION(detection_probability > 0 && detection_probability <= 1);
  HISFM_CHECK_OPTION(distractor_ratio >= 0 && distractor_ratio <= 10);
  HISFM_CHECK_OPTION(max_view_angle > 0 && max_view_angle < 180);
  HISFM_CHECK_OPTION(max_scale_ratio >= 1);
  HISFM_CHECK_OPTION(outlier_ratio >= 0 && outlier_ratio <= 1);
  HISFM_CHECK_OPTION(min_num_inliers >= 8);
  HISFM_CHECK_OPTION(max_error > 0);
  HISFM_CHECK_OPTION(min_inlier_ratio >= 0 && min_inlier_ratio <= 1);
  HISFM_CHECK_OPTION(!colmap_path.empty());
}

}  // namespace hisfm
