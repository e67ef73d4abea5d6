// Tuning / held-out protocol on the synthetic scene families
// (hisfm/synth/scene_families.h). For every family, size and seed it
// generates an instance with randomized parameters (`hisfm synth
// --randomize_family 1`: the family, size and seed define it), runs this
// build's `hisfm mapper` on it and, with --colmap 1, vanilla `colmap mapper`,
// judges both against the ground truth with the project's evaluator (correct:
// at least 95% of image pairs within 5 degrees in relative rotation and
// translation direction, 95% of camera centres within 5% of the scene extent
// after alignment, every image registered, not split), and prints a
// Markdown table with one row per instance and a summary per family and per
// split (means over instances; a failed run or one without a model counts
// as 0% of pairs within 5 degrees).
//
// Split rule: odd seeds form the "tuning" split, even seeds the "held-out"
// split. Thresholds are chosen on tuning instances only and reported on the
// held-out ones.
//
// A family is named as for `hisfm synth --scene`; "NAME:control" is its
// control (--unique_pattern 1: no repeated structure, nothing true should be
// rejected).
//
//   build/bench/family_sweep [--families facade_street,block_loop,...]
//                            [--sizes 40,150] [--seeds 1-8]
//                            [--hisfm_args "--HiSfM.top_k 2"] [--colmap 1]
//                            [--keep_dir DIR] [--markdown_path FILE]
//   build/bench/family_sweep --generate_only DIR [...]
//
// Instances are written to DIR/<family>_<size>_s<seed>/ (controls:
// <family>_control_<size>_s<seed>/) as `hisfm synth` writes them; an
// existing instance folder with its synth_summary.json is reused (the
// generation is deterministic). The mappers' outputs go to hisfm/ and
// colmap/ inside it (replaced on a rerun). Without --keep_dir everything
// lives in a temporary folder that is removed at the end. With
// --generate_only only the instances are written, for experiments by hand
// (`hisfm mapper --database_path DIR/facade_street_40_s1/database.db ...`).
#include <sys/wait.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cctype>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <sstream>

#include "hisfm/eval/pose_evaluation.h"
#include "hisfm/io/model.h"
#include "hisfm/synth/synthetic_dataset.h"
#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"
#include "hisfm/util/logging.h"
#include "hisfm/util/string_util.h"
#include "hisfm/util/timer.h"

namespace fs = std::filesystem;
using namespace hisfm;

namespace {

// One family of the --families list.
struct FamilySpec {
  std::string scene;
  bool control = false;
  std::string Label() const { return control ? scene + ":control" : scene; }
  std::string Slug() const { return control ? scene + "_control" : scene; }
};

// One generated instance.
struct Instance {
  FamilySpec family;
  int size = 0;
  uint32_t seed = 0;
  std::string folder;
  SynthFamilyOptions parameters;
  size_t verified_pairs = 0;
  size_t doppelganger_pairs = 0;
  double generate_seconds = 0.0;

  std::string Split() const { return seed % 2 == 1 ? "tuning" : "held-out"; }
};

// The outcome of one mapper on one instance.
struct MapperResult {
  bool ran = false;  // false: the mapper failed (see its log)
  bool correct = false;
  bool oversplit = false;
  bool each_model_right = false;  // split (if so) but no model folded
  double within5 = NAN;
  double centers = NAN;  // the largest model's centres within 5% of extent
  size_t registered = 0;
  size_t num_models = 0;
  double seconds = 0.0;
};

std::vector<std::string> SplitList(const std::string& text) {
  std::vector<std::string> items;
  std::stringstream in(text);
  std::string item;
  while (std::getline(in, item, ',')) {
    if (!item.empty()) items.push_back(item);
  }
  return items;
}

int ParseInt(const std::string& text, const std::string& what) {
  size_t used = 0;
  int value = 0;
  try {
    value = std::stoi(text, &used);
  } catch (const std::exception&) {
    used = 0;
  }
  ThrowUnless(used == text.size() && !text.empty(),
              StrCat("invalid ", what, " '", text, "'"));
  return value;
}

// "1-4,7" -> 1, 2, 3, 4, 7.
std::vector<uint32_t> ParseSeeds(const std::string& text) {
  std::vector<uint32_t> seeds;
  for (const std::string& item : SplitList(text)) {
    const size_t dash = item.find('-');
    const int first = ParseInt(item.substr(0, dash), "seed");
    const int last = dash == std::string::npos
                         ? first
                         : ParseInt(item.substr(dash + 1), "seed");
    ThrowUnless(first >= 0 && last >= first,
                StrCat("invalid seed range '", item, "'"));
    for (int s = first; s <= last; ++s)
      seeds.push_back(static_cast<uint32_t>(s));
  }
  ThrowUnless(!seeds.empty(), "--seeds is empty");
  return seeds;
}

std::vector<FamilySpec> ParseFamilies(const std::string& text) {
  std::vector<FamilySpec> families;
  for (const std::string& item : SplitList(text)) {
    FamilySpec spec;
    const size_t colon = item.find(':');
    spec.scene = item.substr(0, colon);
    if (colon != std::string::npos) {
      ThrowUnless(item.substr(colon + 1) == "control",
                  StrCat("invalid family '", item, "' (NAME or NAME:control)"));
      spec.control = true;
    }
    ThrowUnless(IsSynthFamily(ParseSynthSceneType(spec.scene)),
                StrCat(spec.scene, " is a fixed scene, not a family"));
    families.push_back(spec);
  }
  ThrowUnless(!families.empty(), "--families is empty");
  return families;
}

// Splits a command line into words: blanks separate, single and double
// quotes group.
std::vector<std::string> SplitWords(const std::string& text) {
  std::vector<std::string> words;
  std::string word;
  bool in_word = false;
  char quote = 0;
  for (char c : text) {
    if (quote != 0) {
      if (c == quote) {
        quote = 0;
      } else {
        word += c;
      }
    } else if (c == '\'' || c == '"') {
      quote = c;
      in_word = true;
    } else if (std::isspace(static_cast<unsigned char>(c))) {
      if (in_word) words.push_back(word);
      word.clear();
      in_word = false;
    } else {
      word += c;
      in_word = true;
    }
  }
  ThrowUnless(quote == 0, StrCat("unbalanced quote in '", text, "'"));
  if (in_word) words.push_back(word);
  return words;
}

// Runs argv with its output to `log`; returns the exit code (128 + signal
// when killed).
int RunProcess(const std::vector<std::string>& argv, const std::string& log) {
  const pid_t pid = fork();
  ThrowUnless(pid >= 0, "fork failed");
  if (pid == 0) {
    FILE* f = std::fopen(log.c_str(), "w");
    if (f) {
      dup2(fileno(f), STDOUT_FILENO);
      dup2(fileno(f), STDERR_FILENO);
    }
    std::vector<char*> args;
    for (const std::string& a : argv)
      args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    execvp(args[0], args.data());
    _exit(127);
  }
  int status = 0;
  waitpid(pid, &status, 0);
  if (WIFEXITED(status)) return WEXITSTATUS(status);
  return 128 + (WIFSIGNALED(status) ? WTERMSIG(status) : 0);
}

// Generates (or reuses) one instance in `folder`.
Instance MakeInstance(const FamilySpec& family, int size, uint32_t seed,
                      const std::string& folder) {
  Instance instance;
  instance.family = family;
  instance.size = size;
  instance.seed = seed;
  instance.folder = folder;
  const std::string summary_path = folder + "/synth_summary.json";
  if (!fs::exists(summary_path)) {
    SynthOptions options;
    options.scene = family.scene;
    options.num_images = size;
    options.seed = seed;
    options.family.randomize = true;
    options.family.unique_pattern = family.control;
    std::cerr << "== generating " << folder << "\n";
    WriteSyntheticDataset(options, folder);
  }
  const nlohmann::json json = nlohmann::json::parse(ReadTextFile(summary_path));
  ThrowUnless(json.value("scene", "") == family.scene &&
                  json.value("seed", 0u) == seed &&
                  json.value("num_images", 0) == size,
              StrCat(folder, " holds another instance"));
  const nlohmann::json& f = json.at("family");
  SynthFamilyOptions& p = instance.parameters;
  p.period = f.at("period").get<double>();
  p.camera_spacing = f.at("camera_spacing").get<double>();
  p.facade_distance = f.at("facade_distance").get<double>();
  p.relief_depth = f.at("relief_depth").get<double>();
  p.clutter_density = f.at("clutter_density").get<double>();
  p.block_aspect = f.at("block_aspect").get<double>();
  p.view_angle = f.at("view_angle").get<double>();
  p.symmetry_order = f.at("symmetry_order").get<int>();
  p.ring_radius = f.at("ring_radius").get<double>();
  p.unique_pattern = f.at("unique_pattern").get<bool>();
  instance.verified_pairs = json.at("num_verified_pairs").get<size_t>();
  instance.doppelganger_pairs = json.at("num_doppelganger_pairs").get<size_t>();
  instance.generate_seconds = json.at("seconds").get<double>();
  return instance;
}

// The drawn parameters that matter for the instance's family, briefly.
std::string ParameterCell(const Instance& instance) {
  const SynthFamilyOptions& p = instance.parameters;
  std::string cell;
  if (instance.family.scene == "symmetric_object") {
    cell = StrCat("n=", p.symmetry_order, " R=", FormatFixed(p.ring_radius, 1),
                  " c=", FormatFixed(p.clutter_density, 2));
  } else {
    cell = StrCat("P=", FormatFixed(p.period, 1),
                  " s=", FormatFixed(p.camera_spacing, 2),
                  " D=", FormatFixed(p.facade_distance, 1),
                  " r=", FormatFixed(p.relief_depth, 2),
                  " c=", FormatFixed(p.clutter_density, 2));
    if (instance.family.scene == "block_loop") {
      cell += StrCat(" a=", FormatFixed(p.block_aspect, 2));
    } else if (instance.family.scene == "crossing_streets") {
      cell += StrCat(" θ=", FormatFixed(p.view_angle, 0));
    }
  }
  return cell;
}

// Judges the numbered models in `models` against the instance's ground truth.
void Evaluate(const Instance& instance, const std::string& models,
              MapperResult* r) {
  const std::vector<Reconstruction> reconstructions =
      ReadNumberedModels(models);
  r->num_models = reconstructions.size();
  if (reconstructions.empty()) return;
  const Reconstruction reference = ReadModel(instance.folder + "/ground_truth");
  const MultiModelEvaluation e =
      EvaluateModels(reconstructions, reference, PoseEvaluationOptions());
  r->correct = e.correct;
  r->oversplit = e.oversplit;
  r->each_model_right = e.each_model_right;
  r->within5 = e.largest.verdict_pair_fraction;
  r->centers = e.largest.center_fraction_within;
  r->registered = e.largest.num_registered;
}

MapperResult RunHisfmMapper(const Instance& instance, const std::string& hisfm,
                            const std::vector<std::string>& extra_args) {
  MapperResult r;
  const std::string out = instance.folder + "/hisfm";
  fs::remove_all(out);
  fs::remove_all(out + "_work");
  std::vector<std::string> argv = {hisfm,
                                   "mapper",
                                   "--database_path",
                                   instance.folder + "/database.db",
                                   "--image_path",
                                   instance.folder + "/images",
                                   "--output_path",
                                   out,
                                   "--log_level",
                                   "warn"};
  argv.insert(argv.end(), extra_args.begin(), extra_args.end());
  std::cerr << "== hisfm mapper on " << instance.folder << "\n";
  Timer timer;
  const int code = RunProcess(argv, instance.folder + "/hisfm.log");
  r.seconds = timer.ElapsedSeconds();
  r.ran = code == 0;
  if (r.ran) Evaluate(instance, out, &r);
  return r;
}

MapperResult RunColmapMapper(const Instance& instance,
                             const std::string& colmap) {
  MapperResult r;
  const std::string out = instance.folder + "/colmap";
  fs::remove_all(out);
  fs::create_directories(out + "/sparse");
  // A private copy: colmap opens its database read-write.
  fs::copy_file(instance.folder + "/database.db", out + "/database.db");
  std::cerr << "== colmap mapper on " << instance.folder << "\n";
  Timer timer;
  const int code =
      RunProcess({colmap, "mapper", "--database_path", out + "/database.db",
                  "--image_path", instance.folder + "/images", "--output_path",
                  out + "/sparse"},
                 out + "/colmap.log");
  r.seconds = timer.ElapsedSeconds();
  r.ran = code == 0;
  fs::remove(out + "/database.db");
  if (r.ran) Evaluate(instance, out + "/sparse", &r);
  return r;
}

std::string Verdict(const MapperResult& r) {
  if (!r.ran) return "fail";
  if (r.correct) return "✓";
  return r.oversplit && r.each_model_right ? "✓-" : "×";
}

// "pairs ≤5° | registered | verdict | time" cells; the pairs cell adds the
// largest model's share of centres within 5% of the extent when it is below
// the verdict's 95%.
std::string Cells(const MapperResult& r, int size) {
  if (!r.ran) return StrCat("- | - | fail | ", FormatFixed(r.seconds, 1), " |");
  const PoseEvaluationOptions defaults;
  const std::string centers =
      std::isfinite(r.centers) && r.centers < defaults.min_correct_center_fraction
          ? StrCat(" (centres ", FormatFixed(100.0 * r.centers, 1), "%)")
          : std::string();
  return StrCat(std::isfinite(r.within5)
                    ? FormatFixed(100.0 * r.within5, 1) + "%" + centers
                    : std::string("-"),
                " | ", r.registered, "/", size,
                r.num_models > 1 ? StrCat(" (", r.num_models, " models)") : "",
                " | ", Verdict(r), " | ", FormatFixed(r.seconds, 1), " |");
}

// Counts of one summary row.
struct Tally {
  size_t instances = 0;
  size_t hisfm_correct = 0;
  size_t colmap_correct = 0;
  double hisfm_within5 = 0.0;
  double colmap_within5 = 0.0;
  double hisfm_seconds = 0.0;
  double colmap_seconds = 0.0;

  void Add(const MapperResult& hisfm, const MapperResult& colmap) {
    ++instances;
    hisfm_correct += hisfm.correct;
    colmap_correct += colmap.correct;
    hisfm_within5 += std::isfinite(hisfm.within5) ? hisfm.within5 : 0.0;
    colmap_within5 += std::isfinite(colmap.within5) ? colmap.within5 : 0.0;
    hisfm_seconds += hisfm.seconds;
    colmap_seconds += colmap.seconds;
  }
  std::string Row(const std::string& label, bool with_colmap) const {
    const double n = std::max<size_t>(instances, 1);
    std::string row =
        StrCat("| ", label, " | ", instances, " | ", hisfm_correct, "/",
               instances, " | ", FormatFixed(100.0 * hisfm_within5 / n, 1),
               "% | ", FormatFixed(hisfm_seconds / n, 1), " |");
    if (with_colmap) {
      row += StrCat(
          " ", colmap_correct, "/", instances, " | ",
          FormatFixed(100.0 * colmap_within5 / n, 1), "% | ",
          FormatFixed(colmap_seconds / n, 1), " | ",
          FormatFixed(hisfm_seconds / std::max(colmap_seconds, 1e-9), 2), " |");
    }
    return row + "\n";
  }
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app(
      "Tuning / held-out protocol on the synthetic scene families: "
      "HiSfM (and colmap) on randomized instances; odd seeds = tuning, even "
      "seeds = held-out");
  std::string families_arg =
      "facade_street,block_loop,crossing_streets,symmetric_object";
  std::string sizes_arg = "40,150";
  std::string seeds_arg = "1-8";
  std::string hisfm_args;
  bool run_colmap = false;
  std::string keep_dir;
  std::string generate_only;
  std::string markdown_path;
  std::string hisfm =
      (fs::path(argv[0]).parent_path().parent_path() / "hisfm").string();
  std::string colmap = "colmap";
  std::string log_level = "warn";
  app.add_option("--families", families_arg,
                 "Comma-separated families (hisfm synth --scene names); "
                 "NAME:control for a family's control")
      ->capture_default_str();
  app.add_option("--sizes", sizes_arg, "Comma-separated image counts")
      ->capture_default_str();
  app.add_option("--seeds", seeds_arg,
                 "Seeds, e.g. 1-8 or 1,3,5 (odd: tuning, even: held-out)")
      ->capture_default_str();
  app.add_option("--hisfm_args", hisfm_args,
                 "Extra arguments of hisfm mapper, e.g. \"--HiSfM.top_k 2\"");
  app.add_option("--colmap", run_colmap, "Also run vanilla colmap mapper (0/1)")
      ->capture_default_str();
  app.add_option("--keep_dir", keep_dir,
                 "Keep instances and outputs in DIR/<family>_<size>_s<seed>/ "
                 "(default: a temporary folder, removed)");
  app.add_option("--generate_only", generate_only,
                 "Only write the instances into DIR/<family>_<size>_s<seed>/");
  app.add_option("--markdown_path", markdown_path,
                 "Also write the tables here");
  app.add_option("--hisfm", hisfm, "The hisfm executable")
      ->capture_default_str();
  app.add_option("--colmap_path", colmap, "The colmap executable")
      ->capture_default_str();
  app.add_option("--log_level", log_level,
                 "Log level of the generator: trace, debug, info, warn, error")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  std::string temporary;
  try {
    SetLogLevel(log_level);
    const std::vector<FamilySpec> families = ParseFamilies(families_arg);
    std::vector<int> sizes;
    for (const std::string& item : SplitList(sizes_arg)) {
      sizes.push_back(ParseInt(item, "size"));
      ThrowUnless(sizes.back() >= 2, StrCat("invalid size ", item));
    }
    ThrowUnless(!sizes.empty(), "--sizes is empty");
    const std::vector<uint32_t> seeds = ParseSeeds(seeds_arg);
    const std::vector<std::string> extra_args = SplitWords(hisfm_args);

    std::string root = !generate_only.empty() ? generate_only : keep_dir;
    if (root.empty()) {
      std::string pattern =
          (fs::temp_directory_path() / "hisfm-family-sweep-XXXXXX").string();
      ThrowUnless(mkdtemp(pattern.data()) != nullptr,
                  "cannot create a temporary folder");
      root = temporary = pattern;
    }
    fs::create_directories(root);

    std::ostringstream table;
    size_t printed = 0;
    auto flush = [&]() {
      const std::string text = table.str();
      std::cout << text.substr(printed) << std::flush;
      printed = text.size();
    };
    if (!generate_only.empty()) {
      table
          << "| instance | split | parameters | verified pairs | doppelganger "
             "pairs | generate (s) |\n|---|---|---|---|---|---|\n";
    } else {
      table << "| family | images | seed | split | parameters | HiSfM pairs "
               "≤5° | "
               "reg | ✓/× | time (s) |";
      if (run_colmap)
        table << " COLMAP pairs ≤5° | reg | ✓/× | time (s) | ratio |";
      table << "\n|---|---|---|---|---|---|---|---|---|";
      if (run_colmap) table << "---|---|---|---|---|";
      table << "\n";
    }
    flush();

    std::map<std::string, Tally> by_family;
    std::map<std::string, Tally> by_split;
    for (const FamilySpec& family : families) {
      for (const int size : sizes) {
        for (const uint32_t seed : seeds) {
          const std::string name = StrCat(family.Slug(), "_", size, "_s", seed);
          const Instance instance =
              MakeInstance(family, size, seed, root + "/" + name);
          if (!generate_only.empty()) {
            table << "| " << name << " | " << instance.Split() << " | "
                  << ParameterCell(instance) << " | " << instance.verified_pairs
                  << " | " << instance.doppelganger_pairs << " | "
                  << FormatFixed(instance.generate_seconds, 1) << " |\n";
            flush();
            continue;
          }
          const MapperResult h = RunHisfmMapper(instance, hisfm, extra_args);
          MapperResult c;
          if (run_colmap) c = RunColmapMapper(instance, colmap);
          table << "| " << family.Label() << " | " << size << " | " << seed
                << " | " << instance.Split() << " | " << ParameterCell(instance)
                << " | " << Cells(h, size);
          if (run_colmap) {
            table << " " << Cells(c, size) << " "
                  << (h.ran && c.ran && c.seconds > 0
                          ? FormatFixed(h.seconds / c.seconds, 2)
                          : std::string("-"))
                  << " |";
          }
          table << "\n";
          flush();
          by_family[StrCat(family.Label(), " | ", instance.Split())].Add(h, c);
          by_split[instance.Split()].Add(h, c);
        }
      }
    }
    if (generate_only.empty()) {
      std::ostringstream summary;
      summary
          << "\n| family | split | instances | HiSfM ✓ | HiSfM mean pairs ≤5° "
             "| HiSfM mean time (s) |";
      if (run_colmap) {
        summary << " COLMAP ✓ | COLMAP mean pairs ≤5° | COLMAP mean time (s) "
                   "| time ratio |";
      }
      summary << "\n|---|---|---|---|---|---|";
      if (run_colmap) summary << "---|---|---|---|";
      summary << "\n";
      for (const auto& [label, tally] : by_family) {
        summary << tally.Row(label, run_colmap);
      }
      for (const auto& [split, tally] : by_split) {
        summary << tally.Row("all | " + split, run_colmap);
      }
      table << summary.str();
      flush();
    }
    if (!markdown_path.empty()) WriteFileAtomically(markdown_path, table.str());
    if (!temporary.empty()) fs::remove_all(temporary);
  } catch (const std::exception& e) {
    std::cerr << "error: " << e.what() << "\n";
    if (!temporary.empty()) {
      std::error_code ec;
      fs::remove_all(temporary, ec);
    }
    return 1;
  }
  return 0;
}
