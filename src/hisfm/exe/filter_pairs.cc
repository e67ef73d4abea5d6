// `hisfm filter_pairs`: the exhaustive-verification baseline.
#include <CLI/CLI.hpp>
#include <iostream>

#include "hisfm/cli/option_flags.h"
#include "hisfm/exe/command.h"
#include "hisfm/recon/exhaustive_filter.h"

namespace hisfm {
namespace {

int RunFilterPairsCommand(int argc, char** argv) {
  CLI::App app(
      "Exhaustive baseline: score every verified pair with the verifier and "
      "write a database without the rejected pairs, for vanilla colmap "
      "mapper.",
      "hisfm filter_pairs");
  std::string database_path, image_path, output_path;
  std::string log_level = "info";
  ExhaustiveFilterOptions options;
  OptionFlagMap flags;
  app.add_option("--database_path", database_path, "COLMAP database")
      ->required();
  app.add_option("--image_path", image_path,
                 "Folder of the photos (for verifiers that read them)");
  app.add_option("--output_path", output_path,
                 "Filtered database to write (must not exist)")
      ->required();
  AddOptionFlag(app, &flags, "--HiSfM.min_num_matches", options.min_num_matches,
                "Ignore verified pairs with fewer inliers")
      ->capture_default_str();
  AddOptionFlag(app, &flags, "--HiSfM.top_k", options.communities.top_k,
                "Strongest neighbours per image for the verifier's context")
      ->capture_default_str();
  AddOptionFlag(app, &flags, "--HiSfM.verify_threshold",
                options.verify_threshold, "Minimum score of a kept pair")
      ->capture_default_str();
  AddOptionFlag(app, &flags, "--HiSfM.verifier", options.verifier.verifier,
                "builtin, none, scores:FILE or command:CMD")
      ->capture_default_str();
  AddOptionFlag(app, &flags, "--HiSfM.verifier_batch_size", options.batch_size,
                "Pairs per verifier call")
      ->capture_default_str();
  AddOptionFlag(app, &flags, "--HiSfM.min_relative_coverage",
                options.verifier.builtin.min_relative_coverage,
                "builtin verifier: relative inlier coverage scoring 0.5")
      ->capture_default_str();
  AddLogLevelFlag(app, &log_level);
  if (const int code = ParseCommandLine(app, argc, argv); code >= 0) {
    return code;
  }
  CheckOptionFlags(flags, [&] { options.Check(); });
  std::cout << FilterPairsExhaustively(database_path, image_path, output_path,
                                       options)
                   .dump(2)
            << "\n";
  return 0;
}

HISFM_REGISTER_COMMAND("filter_pairs",
                       "exhaustive baseline: verify every pair, drop rejected",
                       RunFilterPairsCommand);

}  // namespace
}  // namespace hisfm
