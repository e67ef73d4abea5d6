// COLMAP-style command-line flags for HiSfM's option structs.
#pragma once

#include <CLI/CLI.hpp>
#include <functional>
#include <map>
#include <string>
#include <vector>

#include "hisfm/eval/pose_evaluation.h"
#include "hisfm/recon/hierarchical_mapper.h"

namespace hisfm {

/// Adds --HiSfM.* flags for every field of the hierarchy, verifier and mapper
/// options, plus --colmap_path.
void AddHierarchicalMapperFlags(CLI::App& app,
                                HierarchicalMapperOptions* options);

/// Adds the paths of `hisfm mapper`: --database_path, --image_path and
/// --output_path (required) and --work_path.
void AddMapperPathFlags(CLI::App& app, MapperPaths* paths);

/// Adds --log_level and applies it after parsing.
void AddLogLevelFlag(CLI::App& app, std::string* level);

/// The `Mapper.*` entries (key without dashes, value) of an options file.
std::map<std::string, std::string> ReadMapperEntries(const std::string& path);

/// Splits CLI11's unparsed arguments into `--Mapper.*` pass-through pairs
/// (for colmap mapper): command-line flags, then the keys of the options file
/// that no flag has, with their values from `file_entries` (the command line
/// wins over the file). Throws hisfm::Error on any other unknown argument.
std::vector<std::string> TakeMapperPassThrough(
    const std::vector<std::string>& remaining,
    const std::map<std::string, std::string>& file_entries = {});

/// Parses a command line. Help prints the help (exit code 0); a parse error
/// prints one line, "error: ... (see -h)", on stderr (exit code 1). Returns
/// -1 when the command should go on, else the exit code.
int ParseCommandLine(CLI::App& app, int argc, char** argv);

/// Adds the mapper flags (AddHierarchicalMapperFlags), --log_level and the
/// options file --project_path to a command, which then takes unknown
/// arguments (the `--Mapper.*` pass-through flags).
void PrepareMapperCommand(CLI::App& app, HierarchicalMapperOptions* options,
                          std::string* log_level);

/// The flag that sets each option, by the option's address
/// (OptionError::field()): an explicit mapping, no guessing from names.
using OptionFlagMap = std::map<const void*, std::string>;

/// app.add_option(flag, option, help), recording in `flags` that `flag`
/// sets `option`.
template <typename T>
CLI::Option* AddOptionFlag(CLI::App& app, OptionFlagMap* flags,
                           const std::string& flag, T& option,
                           const std::string& help = "") {
  (*flags)[&option] = flag;
  return app.add_option(flag, option, help);
}

/// Adds the options of the pose evaluation (`hisfm evaluate`):
/// --verdict_threshold_deg, --min_correct_pair_fraction, --center_threshold,
/// --min_correct_center_fraction, --require_all_registered, --min_model_size,
/// --alignment_inlier_threshold;
/// `flags` records the option each flag sets (CheckOptionFlags).
void AddPoseEvaluationFlags(CLI::App& app, PoseEvaluationOptions* options,
                            OptionFlagMap* flags);

/// Runs `check` (an options' Check()); an OptionError about an option of
/// `flags` is rethrown naming its flag ("invalid option --num_images = 1:
/// must be >= 2"), any other error as it is.
void CheckOptionFlags(const OptionFlagMap& flags,
                      const std::function<void()>& check);

/// The flag (AddHierarchicalMapperFlags) that sets each option of `options`.
OptionFlagMap MapperOptionFlags(const HierarchicalMapperOptions& options);

/// options.Check(); an OptionError names the flag that sets the failing
/// option ("invalid option --HiSfM.top_k = 0: must be >= 1").
void CheckMapperOptions(const HierarchicalMapperOptions& options);

/// Adds the mapper flags (AddHierarchicalMapperFlags) and --log_level to a
/// command that has added its own, parses it, passes unknown `--Mapper.*`
/// flags to colmap and checks the options. Returns -1 when the command
/// should go on, else the exit code (help, parse error).
int ParseMapperCommand(CLI::App& app, int argc, char** argv,
                       HierarchicalMapperOptions* options,
                       std::string* log_level);

/// The options as INI text (COLMAP project-file style), for the record and
/// to be read back with --project_path: every option, paths made absolute,
/// and the `--Mapper.*` pass-through flags (`mapper_args`, name and value
/// pairs) as `Mapper.*` keys.
std::string OptionsRecord(CLI::App& app,
                          const std::vector<std::string>& mapper_args);

}  // namespace hisfm
