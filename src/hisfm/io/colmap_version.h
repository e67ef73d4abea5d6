// The COLMAP releases hisfm drives through the `colmap` command line, and the
// names each release gives the options hisfm passes.
//
// COLMAP renames options between releases (from COLMAP's own sources,
// src/colmap/controllers/option_manager.cc and exe/*.cc at the release tags,
// and its CHANGELOG):
//   3.9:  SiftMatching.{min_num_inliers, max_error, min_inlier_ratio,
//         confidence, max_num_trials, multiple_models, compute_relative_pose}
//         became TwoViewGeometry.*;
//   3.12: rigs and frames: Mapper.ba_global_images_{ratio,freq},
//         snapshot_images_freq and fix_existing_images became *_frames_*;
//   3.13: `colmap mapper --image_list_path` became --Mapper.image_list_path;
//         SiftExtraction.{use_gpu, num_threads, gpu_index} became
//         FeatureExtraction.*, SiftMatching.{use_gpu, num_threads, gpu_index,
//         guided_matching, max_num_matches} became FeatureMatching.*;
//         Mapper.local_ba_min_tri_angle became Mapper.ba_local_min_tri_angle;
//   3.11: BundleAdjustment.{use_gpu, gpu_index} appeared;
//   4.0:  SiftExtraction.max_image_size became FeatureExtraction.max_image_size,
//         BundleAdjustment.{max_num_iterations, function_tolerance,
//         gradient_tolerance, parameter_tolerance, use_gpu, gpu_index} became
//         BundleAdjustmentCeres.*.
// Every other option hisfm passes keeps its 3.8 name in 3.8 to 4.1. A version
// outside the table is refused: its names are not known.
#pragma once

#include <string>
#include <utility>
#include <vector>

namespace hisfm {

/// The COLMAP releases (major.minor) hisfm knows, oldest first.
enum class ColmapRelease : int {
  k3_8 = 0,
  k3_9,
  k3_10,
  k3_11,
  k3_12,
  k3_13,
  k4_0,
  k4_1,
};

/// Number of ColmapRelease values.
constexpr int kNumColmapReleases = 8;

/// Every ColmapRelease, oldest first.
std::vector<ColmapRelease> AllColmapReleases();

/// "3.8", "4.0", ...
std::string ColmapReleaseName(ColmapRelease release);

/// "3.8, 3.9, ..., 4.1": the releases hisfm knows, for messages.
std::string KnownColmapReleases();

/// A version as `colmap help` prints it.
struct ColmapVersion {
  /// The version as printed: "3.8", "4.0.1", "3.10-dev".
  std::string text;
  int major = 0;
  int minor = 0;
};

/// Reads the version from the output of `colmap help` ("COLMAP 3.8 --
/// Structure-from-Motion ...", "COLMAP 4.0.1 (Commit ...)"). Throws
/// hisfm::Error if there is none.
ColmapVersion ParseColmapVersion(const std::string& help_output);

/// The release of a version (its major.minor); throws hisfm::Error
/// "unsupported COLMAP version X (hisfm knows 3.8, ...)" for any other.
ColmapRelease ColmapReleaseOf(const ColmapVersion& version);

/// One option of the table: its name in every release.
struct ColmapOptionNames {
  /// The colmap command whose option this is, or "" for an option of the
  /// same name in every command (a `Section.name` option).
  std::string command;
  /// The option's name (without dashes) in each release, indexed by
  /// ColmapRelease; "" where the release has no such option.
  std::vector<std::string> names;
};

/// The table: every option hisfm passes to colmap (and the renamed ones a
/// user may pass through), with its name in each release.
const std::vector<ColmapOptionNames>& ColmapOptionTable();

/// The name under which `release`'s `command` takes `option` (given without
/// dashes, by its name in any release). "" if the release has no such
/// option; `option` itself if the table does not list it.
std::string ColmapOptionName(ColmapRelease release, const std::string& command,
                             const std::string& option);

/// Rewrites a colmap argument list (the command, then `--name value` or
/// `--name=value` options) for `release`: every option of the table gets
/// that release's name, and an option given twice (under any of its names)
/// keeps its first value, so that a flag of the user's placed before
/// hisfm's default wins under either name. Throws hisfm::Error naming an
/// option the release does not have.
std::vector<std::string> TranslateColmapArguments(
    ColmapRelease release, const std::vector<std::string>& args);

/// How `colmap mapper` ends its registration loop in `release` (from
/// controllers/incremental_mapper.cc, later incremental_pipeline.cc). In
/// every release a global bundle adjustment follows the last registration
/// when the model grew since the last global one; up to 3.13 the loop stops
/// as soon as no image is left to try, while from 4.0 on (structure-less
/// registration) it first runs one more global bundle adjustment and tries
/// again, so a run that registers nothing still adjusts the model globally.
bool MapperAdjustsGloballyWhenNothingToRegister(ColmapRelease release);

/// What running a colmap executable told about it.
struct ColmapProbe {
  /// The version line, as hisfm has always recorded it (fingerprints).
  std::string line;
  ColmapVersion version;
  ColmapRelease release = ColmapRelease::k3_8;
};

/// Runs `colmap_path help` and reads its version. Throws hisfm::Error with
/// one line if it cannot run ("colmap not found ..."), does not look like
/// COLMAP, or is a version hisfm does not know (named in the message). The
/// answer is remembered for the path during the process; `refresh` asks
/// again.
ColmapProbe ProbeColmap(const std::string& colmap_path, bool refresh = false);

}  // namespace hisfm
