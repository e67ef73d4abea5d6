// `hisfm check_database` and `hisfm check_model`: every problem of an input,
// one a line (the other commands stop at the first one).
#include <CLI/CLI.hpp>
#include <cstdio>
#include <string>
#include <vector>

#include "hisfm/cli/option_flags.h"
#include "hisfm/exe/command.h"
#include "hisfm/io/database_validation.h"
#include "hisfm/io/model_validation.h"
#include "hisfm/util/timer.h"

namespace hisfm {
namespace {

// Prints `lines` on standard output and a summary on standard error;
// returns the exit code (1 if there is any line).
int Report(const std::vector<std::string>& lines, const std::string& what,
           const std::string& path, double seconds) {
  for (const std::string& line : lines) std::printf("%s\n", line.c_str());
  if (lines.empty()) {
    std::fprintf(stderr, "%s %s: no problems (%.2f s)\n", what.c_str(),
                 path.c_str(), seconds);
    return 0;
  }
  std::fprintf(stderr, "error: %s %s has %zu problem(s)\n", what.c_str(),
               path.c_str(), lines.size());
  return 1;
}

int RunCheckDatabase(int argc, char** argv) {
  CLI::App app(
      "Checks a COLMAP database as every hisfm command does before its work, "
      "and prints every problem, one a line (table, row, what is wrong): "
      "blob sizes, column counts, non-finite keypoints and matrices, match "
      "indices, pair ids, camera models and sizes, duplicate image names. "
      "Exits with 1 if there is any: the other commands refuse such a "
      "database.",
      "hisfm check_database");
  std::string database_path;
  DatabaseValidationOptions options;
  OptionFlagMap flags;
  app.add_option("--database_path", database_path, "COLMAP database")
      ->required();
  AddOptionFlag(app, &flags, "--max_problems", options.max_problems,
                "Stop after this many problems (0: all)")
      ->capture_default_str();
  AddOptionFlag(app, &flags, "--check_matches", options.check_matches,
                "Also check the raw matches table")
      ->capture_default_str();
  if (const int code = ParseCommandLine(app, argc, argv); code >= 0) {
    return code;
  }
  CheckOptionFlags(flags, [&] { options.Check(); });
  Timer timer;
  std::vector<std::string> lines;
  for (const DatabaseProblem& p : ValidateDatabase(database_path, options)) {
    lines.push_back(FormatDatabaseProblem(p));
  }
  return Report(lines, "database", database_path, timer.ElapsedSeconds());
}

int RunCheckModel(int argc, char** argv) {
  CLI::App app(
      "Checks a COLMAP model folder (binary or text) as every hisfm command "
      "that reads models does, and prints every problem, one a line: "
      "non-finite poses, points and parameters, tracks naming missing images "
      "or 2D points, 2D points naming missing 3D points, duplicate names. "
      "Exits with 1 if there is any.",
      "hisfm check_model");
  std::string input_path;
  ModelValidationOptions options;
  OptionFlagMap flags;
  app.add_option("--input_path", input_path, "Model folder")->required();
  AddOptionFlag(app, &flags, "--max_problems", options.max_problems,
                "Stop after this many problems (0: all)")
      ->capture_default_str();
  if (const int code = ParseCommandLine(app, argc, argv); code >= 0) {
    return code;
  }
  CheckOptionFlags(flags, [&] { options.Check(); });
  Timer timer;
  std::vector<std::string> lines;
  for (const ModelProblem& p :
       ValidateModel(ReadModelUnvalidated(input_path), options)) {
    lines.push_back(FormatModelProblem(p));
  }
  return Report(lines, "model", input_path, timer.ElapsedSeconds());
}

}  // namespace

HISFM_REGISTER_COMMAND("check_database",
                       "list every problem of a COLMAP database",
                       RunCheckDatabase);
HISFM_REGISTER_COMMAND("check_model", "list every problem of a COLMAP model",
                       RunCheckModel);

}  // namespace hisfm
