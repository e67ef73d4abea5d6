// `hisfm model_stats`: statistics of a COLMAP model (like colmap
// model_analyzer), `hisfm model_converter`: binary <-> text, and
// `hisfm model_export`: points and camera centres as PLY for viewers.
#include <CLI/CLI.hpp>
#include <array>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "hisfm/cli/option_flags.h"
#include "hisfm/exe/command.h"
#include "hisfm/io/model.h"
#include "hisfm/report/model_export.h"
#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"
#include "hisfm/util/logging.h"

namespace fs = std::filesystem;

namespace hisfm {
namespace {

// The model folders at `path`: the folder itself if it holds a model, else
// its numbered sub-folders (0, 1, ...) that do, in numeric order.
std::vector<std::string> ModelFolders(const std::string& path) {
  CheckDirectoryExists(path, "model folder");
  if (HasModel(path)) return {path};
  const std::vector<std::string> found = NumberedModelFolders(path);
  ThrowUnless(!found.empty(),
              StrCat("no COLMAP model (cameras.bin or cameras.txt, or "
                     "numbered model folders) in ",
                     path));
  return found;
}

int RunModelStats(int argc, char** argv) {
  std::string input_path;
  bool json = false;
  CLI::App app(
      "Prints the statistics of a COLMAP model folder (binary or text): "
      "cameras, registered images, points, observations, mean track "
      "length, mean observations per image and mean reprojection error. "
      "A folder of numbered models (sparse/) gives one block per model.",
      "hisfm model_stats");
  app.add_option("--input_path", input_path, "Model folder")->required();
  app.add_flag("--json", json, "Print JSON");
  if (const int code = ParseCommandLine(app, argc, argv); code >= 0) {
    return code;
  }
  const std::vector<std::string> folders = ModelFolders(input_path);
  nlohmann::json all = nlohmann::json::array();
  for (const std::string& folder : folders) {
    const ModelStatistics stats = ComputeModelStatistics(ReadModel(folder));
    if (json) {
      nlohmann::json j = ToJson(stats);
      j["input_path"] = folder;
      all.push_back(j);
    } else {
      if (folders.size() > 1) std::printf("model: %s\n", folder.c_str());
      std::printf("%s", FormatModelStatistics(stats).c_str());
    }
  }
  if (json) {
    std::printf("%s\n", (all.size() == 1 ? all[0] : all).dump(2).c_str());
  }
  return 0;
}

int RunModelConverter(int argc, char** argv) {
  std::string input_path;
  std::string output_path;
  std::string output_type;
  CLI::App app(
      "Converts a COLMAP model folder between binary and text. Binary output "
      "keeps the input's bytes where nothing changed; text output is what "
      "colmap model_converter writes.",
      "hisfm model_converter");
  app.add_option("--input_path", input_path, "Model folder")->required();
  app.add_option("--output_path", output_path,
                 "Existing output folder (files are replaced)")
      ->required();
  app.add_option("--output_type", output_type, "BIN or TXT")
      ->required()
      ->check(CLI::IsMember({"BIN", "TXT"}, CLI::ignore_case));
  if (const int code = ParseCommandLine(app, argc, argv); code >= 0) {
    return code;
  }
  CheckDirectoryExists(output_path, "output folder");
  for (char& c : output_type) c = static_cast<char>(std::toupper(c));
  // The input stays as it is, and a model of the other format is not left
  // beside the new one.
  ThrowUnless(!IsSameOrInside(output_path, input_path),
              StrCat("refusing to write the output into the input model "
                     "folder ",
                     input_path));
  const std::string other = output_type == "BIN" ? "cameras.txt"
                                                 : "cameras.bin";
  ThrowUnless(!fs::exists(fs::path(output_path) / other),
              StrCat("output folder ", output_path, " holds a model in the "
                     "other format (", other, "): choose another folder"));
  const Reconstruction model = ReadModel(input_path);
  if (output_type == "BIN") {
    WriteModelBinary(model, output_path);
  } else {
    WriteModelText(model, output_path);
  }
  return 0;
}

// Parses "R,G,B" (0-255 each).
std::array<uint8_t, 3> ParseColor(const std::string& text) {
  std::array<uint8_t, 3> rgb{};
  unsigned r = 0, g = 0, b = 0;
  char extra = 0;
  ThrowUnless(std::sscanf(text.c_str(), "%u,%u,%u%c", &r, &g, &b, &extra) ==
                      3 &&
                  r < 256 && g < 256 && b < 256,
              StrCat("invalid colour '", text, "': use R,G,B with 0-255"));
  rgb = {static_cast<uint8_t>(r), static_cast<uint8_t>(g),
         static_cast<uint8_t>(b)};
  return rgb;
}

int RunModelExport(int argc, char** argv) {
  std::string input_path, output_path;
  std::string format = "binary";
  std::string camera_color = "255,0,0";
  bool no_points = false, no_cameras = false;
  CLI::App app(
      "Writes a COLMAP model (binary or text) as a PLY point cloud for "
      "viewers such as MeshLab or CloudCompare: the 3D points with their "
      "colours, then the camera centres as vertices of --camera_color.",
      "hisfm model_export");
  app.add_option("--input_path", input_path, "Model folder")->required();
  app.add_option("--output_path", output_path, "PLY file to write")
      ->required();
  app.add_option("--format", format, "binary or ascii")
      ->check(CLI::IsMember({"binary", "ascii"}))
      ->capture_default_str();
  app.add_option("--camera_color", camera_color,
                 "Colour of the camera centres, R,G,B")
      ->capture_default_str();
  app.add_flag("--no_points", no_points, "Leave out the 3D points");
  app.add_flag("--no_cameras", no_cameras, "Leave out the camera centres");
  if (const int code = ParseCommandLine(app, argc, argv); code >= 0) {
    return code;
  }
  PlyExportOptions options;
  options.binary = format == "binary";
  options.include_points = !no_points;
  options.include_cameras = !no_cameras;
  options.camera_color = ParseColor(camera_color);
  CheckOutputFile(output_path, {input_path});
  const Reconstruction model = ReadModel(input_path);
  const PlyExportSummary summary =
      WriteModelPly(model, output_path, options);
  HISFM_LOG_INFO("wrote {} points and {} camera centres to {}",
                 summary.num_points, summary.num_cameras, output_path);
  return 0;
}

}  // namespace

HISFM_REGISTER_COMMAND("model_stats",
                       "print the statistics of a COLMAP model",
                       RunModelStats);
HISFM_REGISTER_COMMAND("model_converter",
                       "convert a COLMAP model between binary and text",
                       RunModelConverter);
HISFM_REGISTER_COMMAND("model_export",
                       "write a model's points and cameras as PLY",
                       RunModelExport);

}  // namespace hisfm
