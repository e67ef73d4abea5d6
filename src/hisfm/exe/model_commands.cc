// `hisfm model_stats`: statistics of a COLMAP model (like colmap
// model_analyzer), and `hisfm model_converter`: binary <-> text.
#include <CLI/CLI.hpp>
#include <cctype>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <string>

#include "hisfm/exe/command.h"
#include "hisfm/io/model.h"
#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"

namespace hisfm {
namespace {

int RunModelStats(int argc, char** argv) {
  std::string input_path;
  bool json = false;
  CLI::App app(
      "Prints the statistics of a COLMAP model folder (binary or text): "
      "cameras, registered images, points, observations, mean track "
      "length, mean observations per image and mean reprojection error.");
  app.add_option("--input_path", input_path, "Model folder")->required();
  app.add_flag("--json", json, "Print JSON");
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  const Reconstruction model = ReadModel(input_path);
  const size_t num_observations = model.NumObservations();
  const double mean_observations_per_image =
      model.images.empty() ? 0.0
                           : static_cast<double>(num_observations) /
                                 static_cast<double>(model.images.size());
  if (json) {
    nlohmann::json j;
    j["input_path"] = input_path;
    j["num_cameras"] = model.cameras.size();
    j["num_images"] = model.NumRegImages();
    j["num_points3D"] = model.NumPoints3D();
    j["num_observations"] = num_observations;
    j["mean_track_length"] = model.MeanTrackLength();
    j["mean_observations_per_image"] = mean_observations_per_image;
    j["mean_reprojection_error"] = model.MeanReprojectionError();
    std::printf("%s\n", j.dump(2).c_str());
    return 0;
  }
  std::printf("cameras: %zu\n", model.cameras.size());
  std::printf("images: %zu\n", model.NumRegImages());
  std::printf("points: %zu\n", model.NumPoints3D());
  std::printf("observations: %zu\n", num_observations);
  std::printf("mean track length: %.6f\n", model.MeanTrackLength());
  std::printf("mean observations per image: %.6f\n",
              mean_observations_per_image);
  std::printf("mean reprojection error: %.6f px\n",
              model.MeanReprojectionError());
  return 0;
}

int RunModelConverter(int argc, char** argv) {
  std::string input_path;
  std::string output_path;
  std::string output_type;
  CLI::App app(
      "Converts a COLMAP model folder between binary and text. Binary output "
      "keeps the input's bytes where nothing changed; text output is what "
      "colmap model_converter writes.");
  app.add_option("--input_path", input_path, "Model folder")->required();
  app.add_option("--output_path", output_path,
                 "Existing output folder (files are replaced)")
      ->required();
  app.add_option("--output_type", output_type, "BIN or TXT")
      ->required()
      ->check(CLI::IsMember({"BIN", "TXT"}, CLI::ignore_case));
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  }
  const Reconstruction model = ReadModel(input_path);
  CheckDirectoryExists(output_path, "output folder");
  for (char& c : output_type) c = static_cast<char>(std::toupper(c));
  if (output_type == "BIN") {
    WriteModelBinary(model, output_path);
  } else {
    WriteModelText(model, output_path);
  }
  return 0;
}

}  // namespace

HISFM_REGISTER_COMMAND("model_stats",
                       "print the statistics of a COLMAP model",
                       RunModelStats);
HISFM_REGISTER_COMMAND("model_converter",
                       "convert a COLMAP model between binary and text",
                       RunModelConverter);

}  // namespace hisfm
