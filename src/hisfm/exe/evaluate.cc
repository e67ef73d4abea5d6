// `hisfm evaluate`: gauge-free pose evaluation of a model against a reference
// (hisfm/eval/pose_evaluation.h).
#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "hisfm/cli/option_flags.h"
#include "hisfm/eval/pose_evaluation.h"
#include "hisfm/exe/command.h"
#include "hisfm/io/database_validation.h"
#include "hisfm/io/model.h"
#include "hisfm/recon/retriangulation.h"
#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"
#include "hisfm/util/interrupt.h"

namespace hisfm {
namespace {

int RunEvaluate(int argc, char** argv) {
  std::string model_path;
  std::string reference_path;
  std::string output_path;
  bool json = false;
  PoseEvaluationOptions options;

  CLI::App app(
      "Evaluates a model's camera poses against a reference model of the "
      "same images (matched by name), gauge-free: relative rotation and "
      "translation-direction errors of all image pairs, and camera-centre "
      "errors after a robust similarity alignment. Several numbered models "
      "(0, 1, ...) beside or inside --model are evaluated together and "
      "reported as oversplit. Correct: every reference image registered, "
      "at least 95% of pairs within 5 degrees and 95% of camera centres "
      "within 5% of the scene extent (see the flags), in one model. Prints "
      "a summary ending with the verdict (exit code 0 whether correct or "
      "not).");
  app.add_option("--model", model_path,
                 "Model folder (binary or text), or a folder of numbered "
                 "model folders")
      ->required();
  app.add_option("--reference", reference_path, "Reference model folder")
      ->required();
  app.add_flag("--json", json, "Print JSON instead of the summary");
  app.add_option("--output_path", output_path, "Also write the JSON here");
  OptionFlagMap flags;
  AddPoseEvaluationFlags(app, &options, &flags);
  std::string database_path, image_path;
  app.add_option("--database_path", database_path,
                 "Also re-triangulate the largest model's poses from this "
                 "(unfiltered) database: the paper's quality proxy")
      ->needs(app.add_option("--image_path", image_path,
                             "Photo folder for --database_path"));
  if (const int code = ParseCommandLine(app, argc, argv); code >= 0) {
    return code;
  }
  CheckOptionFlags(flags, [&] { options.Check(); });
  const std::vector<std::string> model_paths = ResultModelFolders(model_path);
  if (!output_path.empty()) {
    std::vector<std::string> inputs = model_paths;
    inputs.insert(inputs.end(), {reference_path, database_path});
    CheckOutputFile(output_path, inputs);
  }
  if (!database_path.empty()) {
    RequireValidDatabase(database_path);  // One line, before any work.
    CheckDirectoryExists(image_path, "image folder");
  }

  std::vector<Reconstruction> models;
  for (const std::string& path : model_paths) models.push_back(ReadModel(path));
  const Reconstruction reference = ReadModel(reference_path);
  ThrowUnless(!reference.images.empty(),
              StrCat("reference model has no images: ", reference_path));
  const MultiModelEvaluation evaluation =
      EvaluateModels(models, reference, options);

  nlohmann::json j = ToJson(evaluation);
  std::string proxy_text;
  if (!database_path.empty()) {
    InterruptScope interrupt_scope;  // Stops colmap, removes `work`.
    char work[] = "/tmp/hisfm-proxy-XXXXXX";
    ThrowUnless(mkdtemp(work) != nullptr, "cannot create a temporary folder");
    // Removed however Retriangulate ends.
    const std::unique_ptr<char, void (*)(char*)> remove_work(work, [](char* p) {
      std::error_code ec;
      std::filesystem::remove_all(p, ec);
    });
    const RetriangulationStats stats = Retriangulate(
        database_path, image_path, model_paths[evaluation.largest_model], work,
        ColmapRunnerOptions());
    j["retriangulation"] = ToJson(stats);
    proxy_text = StrCat("re-triangulated from the full database: ",
                        stats.points3D, " points, mean reprojection error ",
                        stats.mean_reprojection_error,
                        " px, mean track length ", stats.mean_track_length,
                        "\n");
    ThrowIfInterrupted();
  }
  j["reference_path"] = reference_path;
  j["model_paths"] = model_paths;
  if (!output_path.empty()) {
    WriteFileAtomically(output_path, j.dump(2) + "\n");
  }
  if (json) {
    std::printf("%s\n", j.dump(2).c_str());
  } else {
    std::string header;
    if (model_paths.size() == 1) {
      header = StrCat("model: ", model_paths[0], "\n");
    } else {
      header = "models:";
      for (const std::string& path : model_paths) header += " " + path;
      header += "\n";
    }
    header += StrCat("reference: ", reference_path, "\n");
    std::printf("%s%s%s", header.c_str(), proxy_text.c_str(),
                FormatMultiModelEvaluation(evaluation).c_str());
  }
  return 0;
}

}  // namespace

HISFM_REGISTER_COMMAND("evaluate",
                       "evaluate camera poses against a reference model "
                       "(gauge-free; verdict correct or incorrect)",
                       RunEvaluate);

}  // namespace hisfm
