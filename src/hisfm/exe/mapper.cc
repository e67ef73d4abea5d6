// `hisfm mapper` and `hisfm view_graph`: the hierarchical pipeline on a
// COLMAP database.
#include <CLI/CLI.hpp>
#include <fstream>
#include <iostream>

#include "hisfm/cli/option_flags.h"
#include "hisfm/exe/command.h"
#include "hisfm/recon/hierarchical_mapper.h"
#include "hisfm/report/report_writer.h"
#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"
#include "hisfm/util/interrupt.h"
#include "hisfm/util/logging.h"

namespace hisfm {
namespace {

int RunMapperCommand(int argc, char** argv) {
  CLI::App app(
      "Hierarchical SfM on a COLMAP database: verified skeleton first, then "
      "the leaves, then one global bundle adjustment. Writes COLMAP binary "
      "models to OUTPUT/0, OUTPUT/1, ... and OUTPUT/hisfm_summary.json. "
      "Unknown --Mapper.* flags are passed to colmap mapper.",
      "hisfm mapper");
  MapperPaths paths;
  HierarchicalMapperOptions options;
  std::string log_level = "info";
  AddMapperPathFlags(app, &paths);
  if (const int code =
          ParseMapperCommand(app, argc, argv, &options, &log_level);
      code >= 0) {
    return code;
  }
  // Ctrl-C stops colmap and removes the temporary outputs.
  InterruptScope interrupt_scope;
  paths.options_record = OptionsRecord(app, options.mapper_args);
  RunHierarchicalMapper(paths, options);
  const std::string report_path = paths.output_path + "/report.html";
  WriteReport(ReadMapperReportInput(paths.output_path), report_path);
  HISFM_LOG_INFO("report: {}", report_path);
  ThrowIfInterrupted();
  return 0;
}

int RunViewGraphCommand(int argc, char** argv) {
  CLI::App app(
      "Builds the hierarchy of a COLMAP database (communities, verified "
      "skeleton, leaves) and writes it as JSON.",
      "hisfm view_graph");
  std::string database_path, image_path, output_path;
  HierarchicalMapperOptions options;
  std::string log_level = "info";
  app.add_option("--database_path", database_path, "COLMAP database")
      ->required();
  app.add_option("--image_path", image_path,
                 "Folder of the photos (for verifiers that read them)");
  app.add_option("--output_path", output_path,
                 "JSON file to write (default: standard output)");
  AddHierarchicalMapperFlags(app, &options);
  AddLogLevelFlag(app, &log_level);
  if (const int code = ParseCommandLine(app, argc, argv); code >= 0) {
    return code;
  }
  CheckMapperOptions(options);
  if (!output_path.empty()) CheckOutputFile(output_path, {database_path});
  const nlohmann::json out =
      ComputeViewGraphJson(database_path, image_path, options);
  if (output_path.empty()) {
    std::cout << out.dump(1) << "\n";
  } else {
    WriteFileAtomically(output_path, out.dump(1) + "\n");
  }
  return 0;
}

HISFM_REGISTER_COMMAND("mapper",
                       "hierarchical, disambiguating SfM on a COLMAP database",
                       RunMapperCommand);
HISFM_REGISTER_COMMAND("view_graph",
                       "build the hierarchy only and write it as JSON",
                       RunViewGraphCommand);

}  // namespace
}  // namespace hisfm
