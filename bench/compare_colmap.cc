// Side-by-side benchmark: vanilla `colmap mapper` and `hisfm mapper` on the
// same databases, in one run. For every scene it prints correctness against
// the reference (gauge-free pair errors), registered images, the paper's
// quality proxy (3D points, reprojection error and track length after
// re-triangulating each model's poses from the full database), the mapper
// times and their ratio, as a Markdown table in the layout of the HiSfM
// paper's Table 1.
//
//   build/bench/compare_colmap [--scenes cup,books,synth:symmetric2,...]
//                              [--work_path DIR] [--markdown_path FILE]
#include <CLI/CLI.hpp>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <sstream>

#include "hisfm/eval/pose_evaluation.h"
#include "hisfm/io/model.h"
#include "hisfm/recon/hierarchical_mapper.h"
#include "hisfm/recon/retriangulation.h"
#include "hisfm/synth/synthetic_dataset.h"
#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"
#include "hisfm/util/string_util.h"
#include "hisfm/util/logging.h"
#include "hisfm/util/timer.h"

namespace fs = std::filesystem;
using namespace hisfm;

namespace {

struct Scene {
  std::string name;
  std::string database_path;
  std::string image_path;
  std::string reference_path;  // May be empty.
};

struct MethodResult {
  bool ran = false;
  std::string error;
  double seconds = 0;
  size_t num_models = 0;
  size_t registered = 0;
  bool has_verdict = false;
  bool correct = false;
  bool oversplit = false;
  bool each_model_right = false;  // split (if so) but no model folded
  double within5 = NAN;
  RetriangulationStats proxy;
  size_t verified_bridges = 0;
  size_t verified_pairs = 0;
};

void Evaluate(const Scene& scene, const std::string& models_dir,
              const std::string& work, MethodResult* r) {
  const std::vector<Reconstruction> models = ReadNumberedModels(models_dir);
  r->num_models = models.size();
  size_t largest = 0;
  for (size_t i = 0; i < models.size(); ++i) {
    if (models[i].NumRegImages() > models[largest].NumRegImages()) largest = i;
  }
  for (const Reconstruction& m : models) r->registered += m.NumRegImages();
  if (models.empty()) return;
  if (!scene.reference_path.empty()) {
    const Reconstruction reference = ReadModel(scene.reference_path);
    const MultiModelEvaluation e =
        EvaluateModels(models, reference, PoseEvaluationOptions());
    r->has_verdict = true;
    r->correct = e.correct;
    r->oversplit = e.oversplit;
    r->each_model_right = e.each_model_right;
    r->within5 = e.largest.verdict_pair_fraction;
  }
  r->proxy = Retriangulate(scene.database_path, scene.image_path,
                           models_dir + "/" + std::to_string(largest),
                           work + "/retriangulated", ColmapRunnerOptions());
}

MethodResult RunColmapMapper(const Scene& scene, const std::string& work) {
  MethodResult r;
  fs::create_directories(work + "/sparse");
  // A private copy: colmap opens its database read-write.
  fs::copy_file(scene.database_path, work + "/database.db");
  Timer timer;
  RunColmap(ColmapRunnerOptions(),
            {"mapper", "--database_path", work + "/database.db",
             "--image_path", scene.image_path, "--output_path",
             work + "/sparse"},
            work + "/colmap.log");
  r.seconds = timer.ElapsedSeconds();
  r.ran = true;
  Evaluate(scene, work + "/sparse", work, &r);
  return r;
}

MethodResult RunHisfm(const Scene& scene, const std::string& work,
                      const HierarchicalMapperOptions& options) {
  MethodResult r;
  MapperPaths paths;
  paths.database_path = scene.database_path;
  paths.image_path = scene.image_path;
  paths.output_path = work + "/sparse";
  paths.work_path = work + "/work";
  Timer timer;
  const nlohmann::json summary = RunHierarchicalMapper(paths, options);
  r.seconds = timer.ElapsedSeconds();
  r.ran = true;
  r.verified_bridges = summary["verifier_calls"].get<size_t>();
  r.verified_pairs = summary["verified_pairs"].get<size_t>();
  Evaluate(scene, paths.output_path, work, &r);
  return r;
}

std::string Verdict(const MethodResult& r) {
  if (!r.ran) return "fail";
  if (!r.has_verdict) return "?";
  if (r.correct) return "✓";
  return r.oversplit && r.each_model_right ? "✓-" : "×";
}

std::string Cells(const MethodResult& r) {
  if (!r.ran) return "fail | - | - | - | - | - | - |";
  std::ostringstream out;
  out << Verdict(r) << " | " << r.registered
      << (r.num_models > 1 ? " (" + std::to_string(r.num_models) + " models)"
                           : "")
      << " | "
      << (r.has_verdict ? FormatFixed(100 * r.within5, 1) + "%" : std::string("-"))
      << " | " << r.proxy.points3D
      << " | " << FormatFixed(r.proxy.mean_reprojection_error, 2) << " | "
      << FormatFixed(r.proxy.mean_track_length, 2) << " | " << FormatFixed(r.seconds, 1)
      << " |";
  return out.str();
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("COLMAP vs HiSfM on the same databases, in one run");
  std::string scenes_arg =
      "cup,books,oats,synth:symmetric2,synth:symmetric4,synth:street,"
      "synth:object_control,synth:street_control";
  std::string data_dir;
  std::string work_path = "/tmp/hisfm-bench";
  std::string markdown_path;
  std::string verifier = "builtin";
  int synth_images = 150;
  int synth_seed = 1;
  double synth_background_density = SynthOptions().background_density;
  app.add_option("--scenes", scenes_arg,
                 "Comma-separated: names under yan2017/ in the data folder, "
                 "or synth:<scene>")
      ->capture_default_str();
  app.add_option("--data_dir", data_dir,
                 "Shared data (default $HISFM_DATA_DIR or ../shared/data)");
  app.add_option("--work_path", work_path, "Scratch folder (emptied)")
      ->capture_default_str();
  app.add_option("--markdown_path", markdown_path, "Also write the table here");
  app.add_option("--HiSfM.verifier", verifier, "Verifier for hisfm mapper")
      ->capture_default_str();
  app.add_option("--synth_images", synth_images, "Images per synthetic scene")
      ->capture_default_str();
  app.add_option("--synth_seed", synth_seed, "Seed of the synthetic scenes")
      ->capture_default_str();
  app.add_option("--synth_background_density", synth_background_density,
                 "Unique background of the synthetic scenes (hisfm synth "
                 "--background_density): lower is harder")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  if (data_dir.empty()) {
    const char* env = std::getenv("HISFM_DATA_DIR");
    data_dir = env ? env : "../shared/data";
  }
  try {
    fs::remove_all(work_path);
    fs::create_directories(work_path);
    std::vector<Scene> scenes;
    std::stringstream list(scenes_arg);
    std::string name;
    while (std::getline(list, name, ',')) {
      if (name.empty()) continue;
      Scene s;
      s.name = name;
      if (name.rfind("synth:", 0) == 0) {
        SynthOptions options;
        options.scene = name.substr(6);
        options.num_images = synth_images;
        options.seed = synth_seed;
        options.background_density = synth_background_density;
        const std::string dir = work_path + "/" + options.scene + "_data";
        WriteSyntheticDataset(options, dir);
        s.database_path = dir + "/database.db";
        s.image_path = dir + "/images";
        s.reference_path = dir + "/ground_truth";
      } else {
        const std::string dir = data_dir + "/yan2017/" + name;
        ThrowUnless(fs::exists(dir + "/database.db"),
                    StrCat("scene not found: ", dir,
                           " (set HISFM_DATA_DIR or --data_dir)"));
        s.database_path = dir + "/database.db";
        s.image_path = dir + "/images";
        if (fs::exists(dir + "/reference/images.bin")) {
          s.reference_path = dir + "/reference";
        }
      }
      scenes.push_back(s);
    }

    HierarchicalMapperOptions options;
    options.verifier.verifier = verifier;
    std::ostringstream table;
    size_t printed = 0;
    table << "| scene | COLMAP ✓/× | #reg | pairs ≤5° | #points | err (px) | "
             "len | time (s) | HiSfM ✓/× | #reg | pairs ≤5° | #points | err "
             "(px) | len | time (s) | verified / pairs | time ratio |\n"
          << "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"
             "---|\n";
    double sum_colmap = 0, sum_hisfm = 0;
    for (const Scene& s : scenes) {
      const std::string slug =
          s.name.substr(s.name.find(':') == std::string::npos
                            ? 0
                            : s.name.find(':') + 1);
      LogHeading(StrCat("Scene ", s.name, ": colmap mapper"));
      MethodResult colmap, hisfm;
      try {
        colmap = RunColmapMapper(s, work_path + "/" + slug + "_colmap");
      } catch (const Error& e) {
        colmap.error = e.what();
        HISFM_LOG_ERROR("{}", e.what());
      }
      LogHeading(StrCat("Scene ", s.name, ": hisfm mapper"));
      try {
        hisfm = RunHisfm(s, work_path + "/" + slug + "_hisfm", options);
      } catch (const Error& e) {
        hisfm.error = e.what();
        HISFM_LOG_ERROR("{}", e.what());
      }
      sum_colmap += colmap.seconds;
      sum_hisfm += hisfm.seconds;
      table << "| " << s.name << " | " << Cells(colmap) << " " << Cells(hisfm)
            << " " << hisfm.verified_bridges << " / " << hisfm.verified_pairs
            << " | "
            << (colmap.ran && hisfm.ran
                    ? FormatFixed(hisfm.seconds / colmap.seconds, 2)
                    : std::string("-"))
            << " |\n";
      const std::string text = table.str();
      std::cout << text.substr(printed) << std::flush;
      printed = text.size();
    }
    table << "\nTotal mapper time: COLMAP " << FormatFixed(sum_colmap, 1)
          << " s, HiSfM " << FormatFixed(sum_hisfm, 1) << " s, ratio "
          << FormatFixed(sum_colmap > 0 ? sum_hisfm / sum_colmap : NAN, 2) << "\n";
    std::cout << "\n" << table.str();
    if (!markdown_path.empty()) WriteFileAtomically(markdown_path, table.str());
  } catch (const Error& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
