// COLMAP-style command-line flags for HiSfM's option structs.
#pragma once

#include <CLI/CLI.hpp>
#include <string>
#include <vector>

#include "hisfm/recon/hierarchical_mapper.h"

namespace hisfm {

/// Adds --HiSfM.* flags for every field of the hierarchy, verifier and mapper
/// options, plus --colmap_path.
void AddHierarchicalMapperFlags(CLI::App& app,
                                HierarchicalMapperOptions* options);

/// Adds --log_level and applies it after parsing.
void AddLogLevelFlag(CLI::App& app, std::string* level);

/// Splits CLI11's unparsed arguments into `--Mapper.*` pass-through pairs
/// (for colmap mapper); throws hisfm::Error on any other unknown argument.
std::vector<std::string> TakeMapperPassThrough(
    const std::vector<std::string>& remaining);

/// Adds the mapper flags (AddHierarchicalMapperFlags) and --log_level to a
/// command that has added its own, parses it, passes unknown `--Mapper.*`
/// flags to colmap and checks the options. Returns -1 when the command
/// should go on, else the exit code (help, parse error).
int ParseMapperCommand(CLI::App& app, int argc, char** argv,
                       HierarchicalMapperOptions* options,
                       std::string* log_level);

/// The options as INI text (COLMAP project-file style), for the record.
std::string OptionsRecord(const CLI::App& app);

}  // namespace hisfm
