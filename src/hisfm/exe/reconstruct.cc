// `hisfm reconstruct`: from a folder of photos to a model and its report
// (COLMAP features and matching on the CPU, the hierarchical mapper, the
// HTML report), resumable; and `hisfm report` for a finished mapper run.
#include <CLI/CLI.hpp>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <string>

#include "hisfm/cli/option_flags.h"
#include "hisfm/eval/pose_evaluation.h"
#include "hisfm/exe/command.h"
#include "hisfm/io/database.h"
#include "hisfm/io/model.h"
#include "hisfm/recon/feature_pipeline.h"
#include "hisfm/recon/hierarchical_mapper.h"
#include "hisfm/report/report_writer.h"
#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"
#include "hisfm/util/interrupt.h"
#include "hisfm/util/logging.h"
#include "hisfm/util/timer.h"

namespace fs = std::filesystem;

namespace hisfm {
namespace {

// The lines of an options record that change the mapper's result.
std::string MapperOptionsText(const std::string& record,
                              const std::vector<std::string>& mapper_args) {
  std::istringstream in(record);
  std::string line, out;
  while (std::getline(in, line)) {
    if (line.rfind("HiSfM.", 0) == 0 || line.rfind("colmap_path", 0) == 0) {
      out += line + "\n";
    }
  }
  for (const std::string& a : mapper_args) out += a + "\n";
  return out;
}

// Adds the evaluation against a reference model to a report input.
void AddReference(const std::string& reference_path, ReportInput* input) {
  if (reference_path.empty()) return;
  input->reference = ReadModel(reference_path);
  if (input->model) {
    input->evaluation = ToJson(EvaluateModel(
        *input->model, *input->reference, PoseEvaluationOptions()));
  }
}

// Adds the --Slurm.* flags of `hisfm reconstruct --executor slurm`.
void AddSlurmFlags(CLI::App& app, FeaturePipelineOptions* features,
                   OptionFlagMap* flags) {
  AddOptionFlag(app, flags, "--Slurm.partition",
                features->slurm.partition,
                "slurm: partition of the jobs (default: the cluster's)");
  AddOptionFlag(app, flags, "--Slurm.cpus_per_task",
                features->slurm.cpus_per_task,
                "slurm: CPUs (and colmap threads) of each task")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  AddOptionFlag(app, flags, "--Slurm.mem_mb", features->slurm.mem_mb,
                "slurm: memory of each task in MB (0: the cluster's "
                "default)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  AddOptionFlag(app, flags, "--Slurm.time_limit_minutes",
                features->slurm.time_limit_minutes,
                "slurm: time limit of each task (0: the partition's)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  AddOptionFlag(app, flags, "--Slurm.max_parallel_tasks",
                features->slurm.max_parallel_tasks,
                "slurm: tasks of an array running at once (0: no limit)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  AddOptionFlag(app, flags, "--Slurm.max_retries",
                features->slurm.max_retries,
                "slurm: submissions of a failing shard after its first")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  AddOptionFlag(app, flags, "--Slurm.shard_size", features->shard_size,
                "slurm: photos per extraction (and retrieval) shard (0: "
                "about 8 shards)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  AddOptionFlag(app, flags, "--Slurm.block_group_size",
                features->block_group_size,
                "slurm: photos per group of the exhaustive pair blocks, a "
                "block pairing two groups (0: about 4 groups, 10 blocks)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  AddOptionFlag(app, flags, "--Slurm.sbatch_path",
                features->slurm.sbatch_path, "slurm: the sbatch command")
      ->capture_default_str();
  AddOptionFlag(app, flags, "--Slurm.squeue_path",
                features->slurm.squeue_path, "slurm: the squeue command")
      ->capture_default_str();
  AddOptionFlag(app, flags, "--Slurm.scancel_path",
                features->slurm.scancel_path, "slurm: the scancel command")
      ->capture_default_str();
}

// Adds the flags of the feature pipeline (matcher, executor, Slurm,
// cameras), recording the option each sets in `flags`.
void AddFeaturePipelineFlags(CLI::App& app, FeaturePipelineOptions* features,
                             OptionFlagMap* flags) {
  AddOptionFlag(app, flags, "--matcher", features->matcher,
                "exhaustive (every pair), sequential (photos taken in name "
                "order) or vocab_tree (each photo with the --num_neighbors "
                "photos a vocabulary tree retrieves)")
      ->check(CLI::IsMember({"exhaustive", "sequential", "vocab_tree"}))
      ->capture_default_str();
  AddOptionFlag(app, flags, "--vocab_tree_path",
                features->vocab_tree_path,
                "vocab_tree: a vocabulary tree in COLMAP's format; default: "
                "one built from the photos' own descriptors (colmap "
                "vocab_tree_builder) into WORKSPACE/vocab_tree.bin, once");
  AddOptionFlag(app, flags, "--num_neighbors", features->num_neighbors,
                "vocab_tree: photos retrieved and matched per photo")
      ->check(CLI::PositiveNumber)
      ->capture_default_str();
  AddOptionFlag(app, flags, "--vocab_tree_num_words",
                features->vocab_tree_num_words,
                "vocab_tree: visual words of a built tree (0: 64 per photo, "
                "a power of two within 256-65536)")
      ->check(CLI::NonNegativeNumber)
      ->capture_default_str();
  AddOptionFlag(app, flags, "--executor", features->executor,
                "local (colmap on this machine) or slurm (feature "
                "extraction and matching as Slurm job arrays; the "
                "workspace, photos and colmap must be on a filesystem the "
                "nodes share)")
      ->check(CLI::IsMember({"local", "slurm"}))
      ->capture_default_str();
  AddSlurmFlags(app, features, flags);
  AddOptionFlag(app, flags, "--camera_mode", features->camera_mode,
                "single (one camera for all photos), per_image, or auto "
                "(single if all photos have the same size)")
      ->check(CLI::IsMember({"single", "per_image", "auto"}))
      ->capture_default_str();
  AddOptionFlag(app, flags, "--camera_model", features->camera_model,
                "COLMAP camera model of the new cameras")
      ->capture_default_str();
  AddOptionFlag(app, flags, "--num_threads", features->num_threads,
                "Threads of feature extraction and matching (-1: all)")
      ->capture_default_str();
}

// What the mapper stage did.
struct MapperStage {
  double seconds = 0;
  bool skipped = false;
};

// Stage 4: the hierarchical mapper into `sparse`, unless the ledger holds
// it with the same features, matches, photos and options.
MapperStage RunMapperStage(const FeaturePipelineResult& pipeline,
                           const std::string& image_path,
                           const std::string& record,
                           const HierarchicalMapperOptions& options,
                           const std::string& sparse, StageLedger* ledger) {
  MapperStage stage;
  const std::string summary_path = sparse + "/hisfm_summary.json";
  const std::string mapper_fp = TextFingerprint(
      StrCat("mapper v1\n", pipeline.fingerprint, "\n",
             fs::absolute(image_path).lexically_normal().string(), "\n",
             MapperOptionsText(record, options.mapper_args)));
  if (ledger->IsDone("mapper", mapper_fp) && fs::exists(summary_path)) {
    stage.skipped = true;
    HISFM_LOG_INFO("mapper: unchanged since the last run, skipped");
    return stage;
  }
  ledger->Invalidate("mapper");
  std::error_code ec;
  fs::remove_all(sparse, ec);
  fs::remove_all(sparse + "_work", ec);
  size_t num_images = 0;
  {
    Database db(pipeline.database_path);
    num_images = db.ReadImages().size();
  }
  MapperPaths paths;
  paths.database_path = pipeline.database_path;
  paths.image_path = image_path;
  paths.output_path = sparse;
  paths.work_path = sparse + "_work";
  paths.options_record = record;
  Timer timer;
  {
    // Progress of the largest component's colmap mapper calls.
    ColmapLogFollower follower(paths.work_path + "/component0/colmap.log",
                               "Registering images", num_images,
                               ParseMapperProgress, 0.5);
    RunHierarchicalMapper(paths, options);
    follower.Stop();
  }
  stage.seconds = timer.ElapsedSeconds();
  ledger->MarkDone("mapper", mapper_fp, stage.seconds, {summary_path});
  return stage;
}

// The report's input: the mapper's output in `sparse`, titled after the
// photos' folder, with the feature pipeline's stages and facts.
ReportInput ReconstructionReportInput(const FeaturePipelineResult& pipeline,
                                      const FeaturePipelineOptions& features,
                                      const std::string& image_path,
                                      const std::string& ws,
                                      const std::string& sparse) {
  ReportInput input = ReadMapperReportInput(sparse);
  fs::path folder = fs::absolute(image_path).lexically_normal();
  if (folder.filename().empty()) folder = folder.parent_path();
  if (folder.filename() == "images" && folder.has_parent_path()) {
    folder = folder.parent_path();
  }
  input.title = StrCat("HiSfM reconstruction of ", folder.filename().string());
  auto note = [](bool skipped) {
    return skipped ? std::string("unchanged, time of the last run")
                   : std::string();
  };
  input.stages.push_back({"feature extraction (colmap, CPU)",
                          pipeline.recorded_extraction_seconds,
                          note(pipeline.extraction_skipped)});
  if (features.matcher == "vocab_tree" && features.vocab_tree_path.empty()) {
    input.stages.push_back({"vocabulary tree (colmap vocab_tree_builder)",
                            pipeline.recorded_vocab_tree_seconds,
                            note(!pipeline.vocab_tree_built)});
  }
  input.stages.push_back({StrCat("matching (colmap ", features.matcher,
                                 "_matcher, CPU",
                                 features.executor == "slurm" ? ", Slurm" : "",
                                 ")"),
                          pipeline.recorded_matching_seconds,
                          note(pipeline.matching_skipped)});
  for (const SkippedImageFile& s : pipeline.scan.skipped) {
    input.skipped_files.emplace_back(s.name, s.reason);
  }
  input.facts.insert(
      input.facts.begin(),
      {{"workspace", ws},
       {"photos", StrCat(pipeline.scan.images.size(), " readable, ",
                         pipeline.scan.skipped.size(), " skipped")},
       {"cameras", CameraModeName(pipeline.camera_mode)},
       {"matcher", features.matcher == "vocab_tree"
                       ? StrCat("vocab_tree (", features.num_neighbors,
                                " neighbours)")
                       : features.matcher},
       {"executor", features.executor}});
  return input;
}

// What happened, as a table on standard output: each stage's time (of the
// last run for a skipped one), the registered images, the verdict against
// the reference, the report.
void PrintRunSummary(const FeaturePipelineResult& pipeline,
                     const FeaturePipelineOptions& features,
                     double mapper_seconds, bool mapper_skipped,
                     double report_seconds, double total_seconds,
                     const ReportInput& input, const std::string& sparse,
                     const std::string& report_path) {
  std::printf("\n%-22s %10s\n", "stage", "time");
  auto row = [](const char* name, double seconds, bool skipped) {
    std::printf("%-22s %9.1f s%s\n", name, seconds,
                skipped ? "  (skipped: unchanged; time of the last run)" : "");
  };
  row("feature extraction", pipeline.recorded_extraction_seconds,
      pipeline.extraction_skipped);
  if (features.matcher == "vocab_tree" && features.vocab_tree_path.empty()) {
    row("vocabulary tree", pipeline.recorded_vocab_tree_seconds,
        !pipeline.vocab_tree_built);
  }
  row("matching", pipeline.recorded_matching_seconds,
      pipeline.matching_skipped);
  row("hierarchical mapper", mapper_seconds, mapper_skipped);
  row("report", report_seconds, false);
  std::printf("%-22s %9.1f s\n", "this run", total_seconds);
  const nlohmann::json& summary = input.summary;
  std::printf("\nregistered %s of %zu images in %zu model(s): %s/0\n",
              summary.value("registered_images", nlohmann::json(0))
                  .dump()
                  .c_str(),
              pipeline.scan.images.size(),
              summary.contains("models") ? summary["models"].size() : 0,
              sparse.c_str());
  if (input.evaluation.is_object() && input.evaluation.contains("correct")) {
    std::printf("against the reference: %s\n",
                input.evaluation["correct"].get<bool>()
                    ? "correct"
                    : StrCat("incorrect (",
                             input.evaluation.value("verdict_reason", ""), ")")
                          .c_str());
  }
  std::printf("report: %s\n", report_path.c_str());
}

int RunReconstructCommand(int argc, char** argv) {
  CLI::App app(
      "From a folder of photos to a model: COLMAP feature extraction and "
      "matching on the CPU (on this machine, or as Slurm job arrays with "
      "--executor slurm) into WORKSPACE/database.db, the hierarchical "
      "mapper into WORKSPACE/sparse (models 0, 1, ...), and the report "
      "WORKSPACE/sparse/report.html. Stages whose inputs did not change "
      "since the last run are skipped. Unknown --Mapper.* flags go to "
      "colmap mapper.",
      "hisfm reconstruct");
  std::string image_path, workspace_path, reference_path;
  FeaturePipelineOptions features;
  OptionFlagMap feature_flags;
  HierarchicalMapperOptions options;
  std::string log_level = "info";
  app.add_option("--image_path", image_path, "Folder of the photos")
      ->required();
  app.add_option("--workspace_path", workspace_path,
                 "Workspace folder (created; reused to resume)")
      ->required();
  AddFeaturePipelineFlags(app, &features, &feature_flags);
  app.add_option("--reference_path", reference_path,
                 "Reference model (same image names) to evaluate against "
                 "and overlay in the report");
  if (const int code =
          ParseMapperCommand(app, argc, argv, &options, &log_level);
      code >= 0) {
    return code;
  }
  // Ctrl-C stops colmap and removes the temporary outputs.
  InterruptScope interrupt_scope;
  features.colmap = options.colmap;
  CheckOptionFlags(feature_flags, [&] { features.Check(); });
  if (!reference_path.empty()) {
    CheckDirectoryExists(reference_path, "reference model");
  }
  const std::string record = OptionsRecord(app, options.mapper_args);
  Timer total;

  // Stages 1-3: scan, features, matching.
  const FeaturePipelineResult pipeline =
      RunFeaturePipeline(image_path, workspace_path, features);
  const std::string ws = fs::absolute(workspace_path).lexically_normal();
  StageLedger ledger(ws + "/stages.json");

  // Stage 4: the hierarchical mapper.
  const std::string sparse = ws + "/sparse";
  const MapperStage mapper =
      RunMapperStage(pipeline, image_path, record, options, sparse, &ledger);

  // Stage 5: the report (always rewritten: it is cheap).
  Timer report_timer;
  ReportInput input =
      ReconstructionReportInput(pipeline, features, image_path, ws, sparse);
  AddReference(reference_path, &input);
  const std::string report_path = sparse + "/report.html";
  WriteReport(input, report_path);

  const double recorded_mapper =
      mapper.skipped ? ledger.Seconds("mapper") : mapper.seconds;
  PrintRunSummary(pipeline, features, recorded_mapper, mapper.skipped,
                  report_timer.ElapsedSeconds(), total.ElapsedSeconds(), input,
                  sparse, report_path);
  ThrowIfInterrupted();
  return 0;
}

int RunReportCommand(int argc, char** argv) {
  CLI::App app(
      "Writes the HTML report of a finished `hisfm mapper` run (summary, "
      "view graph, top view of the model, stage times) to "
      "OUTPUT/report.html, optionally with a reference model overlaid and "
      "evaluated.",
      "hisfm report");
  std::string output_path, reference_path, html_path;
  std::string log_level = "info";
  app.add_option("--output_path", output_path,
                 "Output folder of hisfm mapper (with hisfm_summary.json)")
      ->required();
  app.add_option("--reference_path", reference_path,
                 "Reference model (same image names) to overlay and "
                 "evaluate against");
  app.add_option("--html_path", html_path,
                 "HTML file to write (default OUTPUT/report.html)");
  AddLogLevelFlag(app, &log_level);
  if (const int code = ParseCommandLine(app, argc, argv); code >= 0) {
    return code;
  }
  if (html_path.empty()) html_path = output_path + "/report.html";
  std::vector<std::string> inputs = NumberedModelFolders(output_path);
  inputs.insert(inputs.end(),
                {output_path + "/hisfm_summary.json", reference_path});
  CheckOutputFile(html_path, inputs);
  ReportInput input = ReadMapperReportInput(output_path);
  AddReference(reference_path, &input);
  WriteReport(input, html_path);
  HISFM_LOG_INFO("report written to {}", html_path);
  return 0;
}

HISFM_REGISTER_COMMAND("reconstruct",
                       "photos to model: colmap features and matching, the "
                       "hierarchical mapper, the report (resumable)",
                       RunReconstructCommand);
HISFM_REGISTER_COMMAND("report",
                       "write the HTML report of a finished mapper run",
                       RunReportCommand);

}  // namespace
}  // namespace hisfm
