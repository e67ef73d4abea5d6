// `hisfm demo`: a synthetic ambiguous scene reconstructed by vanilla COLMAP
// and by HiSfM, both evaluated against the ground truth, side by side, with
// the HTML report.
#include <CLI/CLI.hpp>
#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <vector>

#include "hisfm/cli/option_flags.h"
#include "hisfm/eval/pose_evaluation.h"
#include "hisfm/exe/command.h"
#include "hisfm/io/model.h"
#include "hisfm/recon/feature_pipeline.h"
#include "hisfm/recon/hierarchical_mapper.h"
#include "hisfm/report/report_writer.h"
#include "hisfm/synth/synthetic_dataset.h"
#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"
#include "hisfm/util/interrupt.h"
#include "hisfm/util/logging.h"
#include "hisfm/util/timer.h"

namespace fs = std::filesystem;

namespace hisfm {
namespace {

constexpr char kMarker[] = "hisfm_demo.json";

std::string DefaultWorkspace() {
  const char* tmp = std::getenv("TMPDIR");
  return StrCat(tmp && *tmp ? tmp : "/tmp", "/hisfm_demo");
}

// The numbered models in `folder`, largest first.
std::vector<Reconstruction> ReadModels(const std::string& folder) {
  std::vector<Reconstruction> models = ReadNumberedModels(folder);
  std::stable_sort(models.begin(), models.end(),
                   [](const Reconstruction& a, const Reconstruction& b) {
                     return a.NumRegImages() > b.NumRegImages();
                   });
  return models;
}

// One method's result against the ground truth.
ReportMethodResult Evaluate(const std::string& method,
                            const std::vector<Reconstruction>& models,
                            const Reconstruction& truth, double seconds) {
  ReportMethodResult r;
  r.method = method;
  r.num_images = truth.NumRegImages();
  r.num_models = models.size();
  r.seconds = seconds;
  for (const Reconstruction& m : models) r.registered_images += m.NumRegImages();
  if (models.empty()) {
    r.evaluation = {{"correct", false},
                    {"verdict", "incorrect"},
                    {"verdict_reason", "no model"}};
  } else {
    r.evaluation =
        ToJson(EvaluateModels(models, truth, PoseEvaluationOptions()));
  }
  return r;
}

std::string PercentWithin5(const nlohmann::json& evaluation) {
  const nlohmann::json& e =
      evaluation.contains("largest") ? evaluation["largest"] : evaluation;
  if (!e.contains("pairs_within")) return "-";
  for (const nlohmann::json& w : e["pairs_within"]) {
    if (std::abs(w.value("threshold_deg", 0.0) - 5.0) < 1e-9) {
      char buf[32];
      std::snprintf(buf, sizeof(buf), "%.1f%%", 100 * w.value("fraction", 0.0));
      return buf;
    }
  }
  return "-";
}

int RunDemoCommand(int argc, char** argv) {
  CLI::App app(
      "Builds a synthetic scene with doppelgangers (an object whose print "
      "repeats twice around it, seen from a ring of cameras), reconstructs it "
      "with vanilla `colmap mapper` and with HiSfM, evaluates both against "
      "the ground truth, prints the comparison and writes the HTML report.",
      "hisfm demo");
  std::string workspace = DefaultWorkspace();
  SynthOptions synth;
  OptionFlagMap synth_flags;
  HierarchicalMapperOptions options;
  std::string log_level = "info";
  app.add_option("--workspace_path", workspace,
                 "Folder for the scene, the models and the report (replaced "
                 "if it holds an earlier demo)")
      ->capture_default_str();
  AddOptionFlag(app, &synth_flags, "--scene", synth.scene, "Synthetic scene")
      ->capture_default_str();
  AddOptionFlag(app, &synth_flags, "--num_images", synth.num_images,
                "Number of images")
      ->capture_default_str();
  AddOptionFlag(app, &synth_flags, "--seed", synth.seed,
                "Random seed of the scene")
      ->capture_default_str();
  if (const int code =
          ParseMapperCommand(app, argc, argv, &options, &log_level);
      code >= 0) {
    return code;
  }
  // Ctrl-C stops colmap and removes the temporary outputs.
  InterruptScope interrupt_scope;
  CheckOptionFlags(synth_flags, [&] { synth.Check(); });
  CheckColmapAvailable(options.colmap);
  workspace = fs::absolute(workspace).lexically_normal().string();
  // A folder of an earlier demo holds kMarker.
  PrepareWorkDirectory(workspace, kMarker);
  WriteFileAtomically(workspace + "/" + kMarker,
                      nlohmann::json({{"scene", synth.scene},
                                      {"num_images", synth.num_images},
                                      {"seed", synth.seed}})
                              .dump(2) +
                          "\n");

  LogHeading(StrCat("Synthetic scene '", synth.scene, "': ", synth.num_images,
                    " images, seed ", synth.seed));
  const std::string scene = workspace + "/scene";
  Timer timer;
  const SynthDatasetSummary made = WriteSyntheticDataset(synth, scene);
  const double synth_seconds = timer.ElapsedSeconds();
  HISFM_LOG_INFO("{} verified pairs, {} of them doppelgangers ({:.1f} s)",
                 made.num_verified_pairs, made.num_doppelganger_pairs,
                 synth_seconds);
  const Reconstruction truth = ReadModelBinary(scene + "/ground_truth");

  LogHeading("Vanilla COLMAP: colmap mapper on all verified pairs");
  const std::string colmap_out = workspace + "/colmap";
  fs::create_directories(colmap_out);
  std::vector<std::string> args = {"mapper",        "--database_path",
                                   scene + "/database.db", "--image_path",
                                   scene + "/images", "--output_path",
                                   colmap_out};
  args.insert(args.end(), options.mapper_args.begin(),
              options.mapper_args.end());
  const double colmap_seconds = RunColmapWithProgress(
      options.colmap, args, workspace + "/colmap.log",
      "COLMAP: registering images", made.num_images, ParseMapperProgress);
  const std::vector<Reconstruction> colmap_models = ReadModels(colmap_out);
  HISFM_LOG_INFO("COLMAP: {} model(s), {:.1f} s", colmap_models.size(),
                 colmap_seconds);

  LogHeading("HiSfM: hierarchical mapper");
  MapperPaths paths;
  paths.database_path = scene + "/database.db";
  paths.image_path = scene + "/images";
  paths.output_path = workspace + "/hisfm";
  paths.work_path = workspace + "/hisfm_work";
  paths.options_record = OptionsRecord(app, options.mapper_args);
  timer.Restart();
  {
    ColmapLogFollower follower(paths.work_path + "/component0/colmap.log",
                               "HiSfM: registering images", made.num_images,
                               ParseMapperProgress, 0.5);
    RunHierarchicalMapper(paths, options);
    follower.Stop();
  }
  const double hisfm_seconds = timer.ElapsedSeconds();
  const std::vector<Reconstruction> hisfm_models = ReadModels(paths.output_path);

  LogHeading("Evaluation against the ground truth");
  const ReportMethodResult colmap_result =
      Evaluate("COLMAP mapper (vanilla)", colmap_models, truth, colmap_seconds);
  const ReportMethodResult hisfm_result =
      Evaluate("HiSfM mapper", hisfm_models, truth, hisfm_seconds);

  ReportInput input = ReadMapperReportInput(paths.output_path);
  input.title = StrCat("HiSfM demo: synthetic scene '", synth.scene, "'");
  input.reference = truth;
  input.evaluation = hisfm_result.evaluation;
  input.comparison = {colmap_result, hisfm_result};
  input.stages.insert(input.stages.begin(),
                      {"generate the synthetic scene", synth_seconds, ""});
  if (!colmap_models.empty()) {
    input.extra_views.push_back(
        {"Vanilla COLMAP's largest model (top view)", colmap_models.front()});
  }
  input.facts.insert(
      input.facts.begin(),
      {{"scene", StrCat(synth.scene, ", ", made.num_images, " images, seed ",
                        synth.seed, ", ", made.num_verified_pairs,
                        " verified pairs (", made.num_doppelganger_pairs,
                        " doppelgangers)")},
       {"ground truth", scene + "/ground_truth"}});
  const std::string report_path = paths.output_path + "/report.html";
  WriteReport(input, report_path);

  std::printf("\n%-24s %-10s %11s %7s %18s %9s\n", "method", "verdict",
              "registered", "models", "pairs within 5deg", "time");
  for (const ReportMethodResult& r : input.comparison) {
    const bool correct = r.evaluation.value("correct", false);
    std::printf("%-24s %-10s %5zu / %-3zu %7zu %18s %7.1f s\n",
                r.method.c_str(), correct ? "correct" : "incorrect",
                r.registered_images, r.num_images, r.num_models,
                PercentWithin5(r.evaluation).c_str(), r.seconds);
  }
  for (const ReportMethodResult& r : input.comparison) {
    if (!r.evaluation.value("correct", false)) {
      std::printf("%s: %s\n", r.method.c_str(),
                  r.evaluation.value("verdict_reason", "").c_str());
    }
  }
  std::printf("\nmodels: %s/0 (COLMAP), %s/0 (HiSfM)\nreport: %s\n",
              colmap_out.c_str(), paths.output_path.c_str(),
              report_path.c_str());
  ThrowIfInterrupted();
  return 0;
}

HISFM_REGISTER_COMMAND("demo",
                       "vanilla COLMAP vs HiSfM on a synthetic ambiguous "
                       "scene, with the report",
                       RunDemoCommand);

}  // namespace
}  // namespace hisfm
