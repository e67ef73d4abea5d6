// `hisfm synth`: writes a synthetic COLMAP workspace with doppelgangers and
// its ground truth (hisfm/synth/synthetic_dataset.h).
#include <CLI/CLI.hpp>
#include <string>

#include "hisfm/cli/option_flags.h"
#include "hisfm/exe/command.h"
#include "hisfm/synth/synthetic_dataset.h"
#include "hisfm/util/error.h"
#include "hisfm/util/logging.h"

namespace hisfm {
namespace {

// Adds the flags of the scene, its cameras and its matches (--scene, ...,
// --outlier_ratio); `scenes` lists the scene names for the help.
void AddSceneFlags(CLI::App& app, const std::string& scenes,
                   SynthOptions* options, OptionFlagMap* flags) {
  AddOptionFlag(app, flags, "--scene", options->scene, "Scene: " + scenes)
      ->capture_default_str();
  AddOptionFlag(app, flags, "--num_images", options->num_images,
                "Number of images")
      ->capture_default_str();
  AddOptionFlag(app, flags, "--seed", options->seed, "Random seed")
      ->capture_default_str();
  AddOptionFlag(app, flags, "--two_view_geometry", options->two_view_geometry,
                "direct (from the ground truth) or colmap (colmap "
                "matches_importer --match_type raw)")
      ->capture_default_str();
  AddOptionFlag(app, flags, "--camera_model", options->camera_model,
                "SIMPLE_PINHOLE, PINHOLE or SIMPLE_RADIAL")
      ->capture_default_str();
  AddOptionFlag(app, flags, "--image_width", options->image_width)
      ->capture_default_str();
  AddOptionFlag(app, flags, "--image_height", options->image_height)
      ->capture_default_str();
  AddOptionFlag(app, flags, "--focal_length", options->focal_length, "Pixels")
      ->capture_default_str();
  AddOptionFlag(app, flags, "--object_density", options->object_density,
                "Multiplier of the points on the object / facades")
      ->capture_default_str();
  AddOptionFlag(app, flags, "--street_block_houses",
                options->street_block_houses,
                "street: houses per block of identical facades")
      ->capture_default_str();
  AddOptionFlag(app, flags, "--background_density", options->background_density,
                "Fixed scenes: multiplier of the points of the unique "
                "background (families: --clutter_density)")
      ->capture_default_str();
  AddOptionFlag(app, flags, "--keypoint_noise", options->keypoint_noise,
                "Keypoint noise standard deviation (pixels)")
      ->capture_default_str();
  AddOptionFlag(app, flags, "--detection_probability",
                options->detection_probability,
                "Probability that a visible point is detected")
      ->capture_default_str();
  AddOptionFlag(app, flags, "--distractor_ratio", options->distractor_ratio,
                "Keypoints without a 3D point, per detected keypoint")
      ->capture_default_str();
  AddOptionFlag(app, flags, "--max_view_angle", options->max_view_angle,
                "Largest viewpoint change of a match (degrees)")
      ->capture_default_str();
  AddOptionFlag(app, flags, "--max_scale_ratio", options->max_scale_ratio,
                "Largest scale change of a match")
      ->capture_default_str();
  AddOptionFlag(app, flags, "--outlier_ratio", options->outlier_ratio,
                "Random wrong matches per correct-appearance match")
      ->capture_default_str();
}

// Adds the flags of the scene families' parameters (--randomize_family,
// --period, ...), recording the option each sets in `flags`.
void AddFamilyFlags(CLI::App& app, SynthFamilyOptions* family,
                    OptionFlagMap* flags) {
  AddOptionFlag(app, flags, "--randomize_family", family->randomize,
                "Families: draw the parameters marked 'random' from their "
                "ranges with the seed (written into synth_summary.json)")
      ->capture_default_str();
  AddOptionFlag(app, flags, "--period", family->period,
                "Streets: period of the facade pattern (m; random 2-8)")
      ->capture_default_str();
  AddOptionFlag(app, flags, "--camera_spacing", family->camera_spacing,
                "Streets: metres between consecutive cameras (random 0.5-2, "
                "period/spacing in 2-10)")
      ->capture_default_str();
  AddOptionFlag(app, flags, "--facade_distance", family->facade_distance,
                "Streets: distance from the camera path to the facades (m; "
                "random 5-15)")
      ->capture_default_str();
  AddOptionFlag(app, flags, "--relief_depth", family->relief_depth,
                "Streets: facade relief, 0 = planar (m; random 0-1.5)")
      ->capture_default_str();
  AddOptionFlag(app, flags, "--clutter_density", family->clutter_density,
                "Families: unique clutter points per repeated point (random "
                "0.1-0.5)")
      ->capture_default_str();
  AddOptionFlag(app, flags, "--block_length", family->block_length,
                "Streets: metres of facade sharing one pattern, 0 = one "
                "pattern everywhere")
      ->capture_default_str();
  AddOptionFlag(app, flags, "--ground_density", family->ground_density,
                "Streets: unique ground points per facade point, 0 = none")
      ->capture_default_str();
  AddOptionFlag(app, flags, "--unique_pattern", family->unique_pattern,
                "Families: every copy of the pattern unique (the control)")
      ->capture_default_str();
  AddOptionFlag(app, flags, "--position_jitter", family->position_jitter,
                "Families: camera position noise (m; random 0-0.2)")
      ->capture_default_str();
  AddOptionFlag(app, flags, "--rotation_jitter", family->rotation_jitter,
                "Families: camera yaw/pitch noise (degrees; random 0-4)")
      ->capture_default_str();
  AddOptionFlag(app, flags, "--block_aspect", family->block_aspect,
                "block_loop: short side / long side (random 0.5-1)")
      ->capture_default_str();
  AddOptionFlag(app, flags, "--view_angle", family->view_angle,
                "crossing_streets: angle between view and street, 90 = "
                "sideways (degrees; random 40-60)")
      ->capture_default_str();
  AddOptionFlag(app, flags, "--symmetry_order", family->symmetry_order,
                "symmetric_object: n-fold print (random 2-4)")
      ->capture_default_str();
  AddOptionFlag(app, flags, "--ring_radius", family->ring_radius,
                "symmetric_object: radius of the camera ring (m; random 3-6)")
      ->capture_default_str();
  AddOptionFlag(app, flags, "--descriptor_noise", family->descriptor_noise,
                "Families: noise of the matcher's descriptor proxy (degrees)")
      ->capture_default_str();
}

int RunSynth(int argc, char** argv) {
  SynthOptions options;
  OptionFlagMap flags;
  std::string output_path;
  std::string log_level = "info";
  std::string scenes;
  for (const std::string& name : SynthSceneNames()) {
    scenes += (scenes.empty() ? "" : ", ") + name;
  }

  CLI::App app("Writes a synthetic scene with doppelgangers as a COLMAP "
               "database (DIR/database.db) with its ground truth "
               "(DIR/ground_truth, binary model) and an empty DIR/images.");
  app.add_option("--output_path", output_path,
                 "Output folder (must not exist or be empty)")
      ->required();
  AddSceneFlags(app, scenes, &options, &flags);
  AddFamilyFlags(app, &options.family, &flags);
  AddOptionFlag(app, &flags, "--min_num_inliers", options.min_num_inliers,
                "Pairs with fewer inliers are not verified")
      ->capture_default_str();
  AddOptionFlag(app, &flags, "--max_error", options.max_error,
                "Inlier threshold (Sampson error, pixels)")
      ->capture_default_str();
  AddOptionFlag(app, &flags, "--min_inlier_ratio", options.min_inlier_ratio,
                "Smallest inlier ratio of a verified pair")
      ->capture_default_str();
  AddOptionFlag(app, &flags, "--write_matches", options.write_matches,
                "Write raw matches into the matches table (direct mode)")
      ->capture_default_str();
  AddOptionFlag(app, &flags, "--num_threads", options.num_threads,
                "-1: every core")
      ->capture_default_str();
  AddOptionFlag(app, &flags, "--colmap_path", options.colmap_path,
                "COLMAP executable (colmap mode)")
      ->capture_default_str();
  AddLogLevelFlag(app, &log_level);
  if (const int code = ParseCommandLine(app, argc, argv); code >= 0) {
    return code;
  }
  CheckOptionFlags(flags, [&] { options.Check(); });
  WriteSyntheticDataset(options, output_path);
  return 0;
}

}  // namespace

HISFM_REGISTER_COMMAND("synth",
                       "Generate a synthetic scene with doppelgangers "
                       "(COLMAP database + ground truth)",
                       RunSynth);

}  // namespace hisfm
