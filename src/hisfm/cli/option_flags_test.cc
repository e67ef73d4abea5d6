#include "hisfm/cli/option_flags.h"

#include <gtest/gtest.h>

#include <set>
#include <string>

#include "hisfm/util/error.h"

namespace hisfm {
namespace {

// The message CheckMapperOptions throws, "" if the options pass.
std::string CheckMessage(const HierarchicalMapperOptions& options) {
  try {
    CheckMapperOptions(options);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(CheckMapperOptions, NamesTheFlagOfTheBadOption) {
  HierarchicalMapperOptions o;
  EXPECT_EQ(CheckMessage(o), "");
  o.hierarchy.communities.top_k = 0;
  EXPECT_EQ(CheckMessage(o), "invalid option --HiSfM.top_k = 0: must be >= 1");
  // Flags whose names differ from their fields' names.
  o = HierarchicalMapperOptions();
  o.verifier.pair_filter.min_distinctive_ratio = 2;
  EXPECT_EQ(CheckMessage(o),
            "invalid option --HiSfM.filter_min_distinctive_ratio = 2: must be "
            "in [0, 1]");
  o = HierarchicalMapperOptions();
  o.verifier.builtin.min_distinctive_ratio = -1;
  EXPECT_EQ(CheckMessage(o),
            "invalid option --HiSfM.min_distinctive_ratio = -1: must be in "
            "[0, 1]");
  o = HierarchicalMapperOptions();
  o.verifier.builtin.grid_cells = 1;
  EXPECT_EQ(CheckMessage(o),
            "invalid option --HiSfM.coverage_grid_cells = 1: must be in "
            "[2, 100]");
  o = HierarchicalMapperOptions();
  o.verifier.verified_hierarchy.trusted_keep_rank = -1;
  EXPECT_EQ(CheckMessage(o),
            "invalid option --HiSfM.trusted_keep_rank = -1: must be >= 0");
  o = HierarchicalMapperOptions();
  o.colmap.colmap_path = "";
  EXPECT_EQ(CheckMessage(o),
            "invalid option --colmap_path = \"\": must be non-empty");
  // An option without a flag keeps its field's name.
  o = HierarchicalMapperOptions();
  o.hierarchy.skeleton.max_verify_batch_size = 0;
  EXPECT_EQ(CheckMessage(o),
            "invalid option max_verify_batch_size = 0: must be >= 1");
}

// Every mapper flag sets its own option: the mapping from options to flags
// has one entry per flag.
TEST(MapperOptionFlags, OneOptionPerFlag) {
  CLI::App app;
  HierarchicalMapperOptions options;
  AddHierarchicalMapperFlags(app, &options);
  std::set<std::string> names;
  for (const CLI::Option* option : app.get_options()) {
    if (option->get_name() != "--help") names.insert(option->get_name());
  }
  const std::map<const void*, std::string> flags = MapperOptionFlags(options);
  std::set<std::string> mapped;
  for (const auto& [field, flag] : flags) mapped.insert(flag);
  EXPECT_EQ(flags.size(), names.size());
  EXPECT_EQ(mapped, names);
  EXPECT_EQ(flags.at(&options.hierarchy.communities.top_k), "--HiSfM.top_k");
  EXPECT_EQ(flags.at(&options.verifier.builtin.max_scan_memory_mb),
            "--HiSfM.verifier_scan_memory_mb");
}

}  // namespace
}  // namespace hisfm
