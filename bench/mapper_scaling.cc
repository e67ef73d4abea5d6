// The mapper at thousands of images, side by side with vanilla colmap in one
// run on the same database: for each size a synthetic scene is generated
// with `hisfm synth` (default: the `street` scene; any scene or family of
// `hisfm synth -h`), and three mappers run on its database one after the
// other, each as its own process with a time budget (killed at it):
//   1. `colmap mapper` with its default options;
//   2. `colmap mapper` with the bundle-adjustment settings hisfm gives its
//      colmap calls (--Mapper.ba_global_images_ratio / points_ratio,
//      ba_global_max_refinements, ba_local_max_refinements,
//      ba_global_function_tolerance: HierarchicalMapperOptions' defaults),
//      so that the hierarchy's own share of the speed-up is visible;
//   3. `hisfm mapper`.
// Each model is judged against the scene's ground truth with the project's
// evaluator (correct: at least 95% of image pairs within 5 degrees and of
// camera centres within 5% of the scene extent, every image registered, one
// model). For each colmap configuration the growth
// exponent of its time is fitted (least squares on log t against log n) on
// the sizes that finished; a size where it ran out of budget gets the
// extrapolated time, marked "~" (the ratio then uses it and says so).
// Prints one Markdown table per comparison (hisfm against colmap's defaults,
// hisfm against colmap with the same bundle-adjustment settings) and the
// fitted exponents.
//
//   build/bench/mapper_scaling [--sizes 500,1000,3000,5000]
//                              [--budget_seconds 7200] [--scene street]
//                              [--synth_args "--street_block_houses 80"]
//                              [--seed 1] [--work_path DIR] [--keep 0]
//                              [--colmap_max_images 0]
//
// At 5,000 images on 2 cores this takes hours (the colmap runs dominate):
// run it with a budget and let the fit say what colmap would have taken, or
// run colmap only up to --colmap_max_images (larger sizes get the fitted
// time, marked "not run"). Each run's time and verdict is printed to stderr
// as it finishes.
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <sstream>

#include "hisfm/eval/pose_evaluation.h"
#include "hisfm/io/model.h"
#include "hisfm/recon/hierarchical_mapper.h"
#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"
#include "hisfm/util/string_util.h"
#include "hisfm/util/timer.h"

namespace fs = std::filesystem;
using namespace hisfm;

namespace {

struct Run {
  bool ran = false;
  bool finished = false;  // false: killed at the budget
  int exit_code = -1;
  double seconds = 0;
  double peak_mb = 0;
  std::string verdict = "-";
  bool correct = false;
  bool ok() const { return ran && finished && exit_code == 0; }
};

// Runs argv in its own process group with output to `log`; kills the group
// after `budget` seconds.
Run RunMeasured(const std::vector<std::string>& argv, const std::string& log,
                double budget) {
  Run r;
  r.ran = true;
  Timer timer;
  const pid_t pid = fork();
  if (pid == 0) {
    setpgid(0, 0);
    FILE* f = std::fopen(log.c_str(), "w");
    if (f) {
      dup2(fileno(f), STDOUT_FILENO);
      dup2(fileno(f), STDERR_FILENO);
    }
    std::vector<char*> args;
    for (const std::string& a : argv) {
      args.push_back(const_cast<char*>(a.c_str()));
    }
    args.push_back(nullptr);
    execvp(args[0], args.data());
    _exit(127);
  }
  setpgid(pid, pid);
  int status = 0;
  struct rusage usage {};
  while (true) {
    if (wait4(pid, &status, WNOHANG, &usage) == pid) break;
    if (timer.ElapsedSeconds() > budget) {
      kill(-pid, SIGKILL);
      wait4(pid, &status, 0, &usage);
      r.seconds = timer.ElapsedSeconds();
      r.peak_mb = usage.ru_maxrss / 1024.0;
      return r;
    }
    usleep(50000);
  }
  r.finished = true;
  r.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : 128;
  r.seconds = timer.ElapsedSeconds();
  r.peak_mb = usage.ru_maxrss / 1024.0;
  return r;
}

// Least-squares fit log t = a + b log n over the finished sizes.
struct GrowthFit {
  double a = NAN;
  double b = NAN;
  size_t points = 0;
  double At(double n) const { return std::exp(a + b * std::log(n)); }
};

GrowthFit Fit(const std::vector<double>& n, const std::vector<Run>& runs) {
  double sx = 0, sy = 0, sxx = 0, sxy = 0;
  GrowthFit f;
  for (size_t i = 0; i < n.size(); ++i) {
    if (!runs[i].ok()) continue;
    const double lx = std::log(n[i]), ly = std::log(runs[i].seconds);
    sx += lx;
    sy += ly;
    sxx += lx * lx;
    sxy += lx * ly;
    ++f.points;
  }
  if (f.points < 2) return f;
  const double k = static_cast<double>(f.points);
  f.b = (k * sxy - sx * sy) / (k * sxx - sx * sx);
  f.a = (sy - f.b * sx) / k;
  return f;
}

void Judge(const std::string& folder, const Reconstruction& reference,
           Run* run) {
  if (!run->ok()) return;
  const std::vector<Reconstruction> models = ReadNumberedModels(folder);
  if (models.empty()) {
    run->verdict = "× no model";
    return;
  }
  const MultiModelEvaluation e =
      EvaluateModels(models, reference, PoseEvaluationOptions());
  run->correct = e.correct;
  run->verdict = StrCat(e.correct ? "✓ " : "× ",
                        FormatFixed(100.0 * e.largest.verdict_pair_fraction, 1),
                        "% ≤5°, ", e.largest.num_registered, " reg.");
}

std::vector<std::string> Words(const std::string& text) {
  std::istringstream in(text);
  std::vector<std::string> out;
  std::string w;
  while (in >> w) out.push_back(w);
  return out;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app(
      "hisfm mapper against colmap mapper (defaults, and hisfm's "
      "bundle-adjustment settings) at growing sizes of a synthetic scene");
  std::string sizes_arg = "500,1000,3000,5000";
  std::string work_path = "/tmp/hisfm-mapper-scaling";
  std::string hisfm = fs::path(argv[0]).parent_path().parent_path() / "hisfm";
  std::string colmap = "colmap";
  std::string scene = "street";
  std::string synth_args;
  std::string hisfm_args;
  int seed = 1;
  double budget = 7200;
  bool keep = false;
  int colmap_max_images = 0;
  app.add_option("--sizes", sizes_arg, "Image counts")->capture_default_str();
  app.add_option("--budget_seconds", budget,
                 "Time budget of each mapper run (killed at it)")
      ->capture_default_str();
  app.add_option("--scene", scene, "hisfm synth --scene")
      ->capture_default_str();
  app.add_option("--synth_args", synth_args,
                 "Further hisfm synth flags, e.g. \"--street_block_houses "
                 "80\"");
  app.add_option("--hisfm_args", hisfm_args, "Further hisfm mapper flags");
  app.add_option("--seed", seed, "hisfm synth --seed")->capture_default_str();
  app.add_option("--work_path", work_path, "Scratch folder (emptied)")
      ->capture_default_str();
  app.add_option("--hisfm", hisfm, "The hisfm executable")
      ->capture_default_str();
  app.add_option("--colmap", colmap, "The colmap executable")
      ->capture_default_str();
  app.add_option("--keep", keep,
                 "Keep each size's scene and models (else removed once "
                 "judged: databases of thousands of images are gigabytes)")
      ->capture_default_str();
  app.add_option("--colmap_max_images", colmap_max_images,
                 "Run colmap only up to this many images (0: every size); "
                 "larger sizes get the time fitted on the smaller ones")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  try {
    fs::remove_all(work_path);
    fs::create_directories(work_path);
    // hisfm's bundle-adjustment settings as colmap mapper flags.
    const HierarchicalMapperOptions defaults;
    const std::vector<std::string> same_ba = {
        "--Mapper.ba_global_images_ratio",
        FormatFixed(defaults.scaffold_ba_global_ratio, 2),
        "--Mapper.ba_global_points_ratio",
        FormatFixed(defaults.scaffold_ba_global_ratio, 2),
        "--Mapper.ba_global_max_refinements",
        std::to_string(defaults.scaffold_ba_global_max_refinements),
        "--Mapper.ba_local_max_refinements",
        std::to_string(defaults.ba_local_max_refinements),
        "--Mapper.ba_global_function_tolerance",
        StrCat(defaults.ba_global_function_tolerance)};
    std::string same_ba_text;
    for (const std::string& w : same_ba) same_ba_text += " " + w;

    std::vector<double> ns;
    std::vector<Run> colmap_default, colmap_same, hisfm_runs;
    std::vector<size_t> pairs;
    std::stringstream list(sizes_arg);
    std::string item;
    while (std::getline(list, item, ',')) {
      const int n = std::stoi(item);
      const std::string dir = StrCat(work_path, "/n", n);
      std::cerr << "== n = " << n << ": hisfm synth --scene " << scene
                << "\n";
      std::vector<std::string> synth = {
          hisfm, "synth", "--scene", scene, "--num_images",
          std::to_string(n), "--seed", std::to_string(seed),
          "--write_matches", "0", "--output_path", dir + "/scene",
          "--log_level", "warn"};
      for (const std::string& w : Words(synth_args)) synth.push_back(w);
      const Run generated = RunMeasured(synth, dir + ".synth.log", 1e9);
      ThrowUnless(generated.ok(), StrCat("hisfm synth failed, see ", dir,
                                         ".synth.log"));
      const std::string db = dir + "/scene/database.db";
      const std::string images = dir + "/scene/images";
      const Reconstruction reference = ReadModel(dir + "/scene/ground_truth");
      size_t verified = 0;
      {
        const std::string summary =
            ReadTextFile(dir + "/scene/synth_summary.json");
        const size_t pos = summary.find("\"num_verified_pairs\"");
        if (pos != std::string::npos) {
          verified = std::stoul(summary.substr(summary.find(':', pos) + 1));
        }
      }
      auto colmap_run = [&](const std::string& name,
                            const std::vector<std::string>& extra) {
        std::cerr << "== n = " << n << ": colmap mapper (" << name << ")\n";
        const std::string out = dir + "/" + name;
        fs::create_directories(out);
        std::vector<std::string> args = {colmap, "mapper", "--database_path",
                                         db, "--image_path", images,
                                         "--output_path", out};
        args.insert(args.end(), extra.begin(), extra.end());
        if (colmap_max_images > 0 && n > colmap_max_images) {
          std::cerr << "   not run (--colmap_max_images)\n";
          return Run();
        }
        Run r = RunMeasured(args, out + ".log", budget);
        Judge(out, reference, &r);
        std::cerr << "   " << FormatFixed(r.seconds, 1) << " s"
                  << (r.finished ? "" : " (killed)") << ", exit "
                  << r.exit_code << ", " << r.verdict << "\n";
        return r;
      };
      ns.push_back(n);
      pairs.push_back(verified);
      colmap_default.push_back(colmap_run("colmap_default", {}));
      colmap_same.push_back(colmap_run("colmap_same_ba", same_ba));
      std::cerr << "== n = " << n << ": hisfm mapper\n";
      std::vector<std::string> h = {hisfm, "mapper", "--database_path", db,
                                    "--image_path", images, "--output_path",
                                    dir + "/hisfm", "--log_level", "warn"};
      for (const std::string& w : Words(hisfm_args)) h.push_back(w);
      Run hr = RunMeasured(h, dir + "/hisfm.log", budget);
      Judge(dir + "/hisfm", reference, &hr);
      std::cerr << "   " << FormatFixed(hr.seconds, 1) << " s"
                << (hr.finished ? "" : " (killed)") << ", exit "
                << hr.exit_code << ", " << hr.verdict << ", "
                << verified << " verified pairs\n";
      hisfm_runs.push_back(hr);
      if (!keep) fs::remove_all(dir + "/scene");
    }

    const GrowthFit fit_default = Fit(ns, colmap_default);
    const GrowthFit fit_same = Fit(ns, colmap_same);
    const GrowthFit fit_hisfm = Fit(ns, hisfm_runs);
    auto time_cell = [&](const Run& r, const GrowthFit& fit, double n) {
      if (r.ok()) return FormatFixed(r.seconds, 1);
      if (!r.ran) {
        return fit.points >= 2 ? StrCat("not run; fit ~",
                                        FormatFixed(fit.At(n), 0))
                               : std::string("not run");
      }
      if (!r.finished) {
        return StrCat("> ", FormatFixed(budget, 0), " (killed",
                      fit.points >= 2
                          ? StrCat("; fit ~", FormatFixed(fit.At(n), 0))
                          : std::string(),
                      ")");
      }
      return StrCat("failed (exit ", r.exit_code, ")");
    };
    auto ratio_cell = [&](const Run& h, const Run& c, const GrowthFit& fit,
                          double n) {
      if (!h.ok()) return std::string("-");
      if (c.ok()) return FormatFixed(h.seconds / c.seconds, 3);
      if (!c.ran) {
        return fit.points >= 2
                   ? StrCat("~", FormatFixed(h.seconds / fit.At(n), 3),
                            " with the fit")
                   : std::string("-");
      }
      if (!c.finished) {
        std::string cell = "< " + FormatFixed(h.seconds / budget, 3);
        if (fit.points >= 2) {
          cell += StrCat(" (~", FormatFixed(h.seconds / fit.At(n), 3),
                         " with the fit)");
        }
        return cell;
      }
      return std::string("-");
    };
    auto table = [&](const std::string& title, const std::vector<Run>& c,
                     const GrowthFit& fit) {
      std::ostringstream t;
      t << "\n### " << title << "\n\n"
        << "| images | verified pairs | colmap mapper (s) | colmap verdict | "
           "hisfm mapper (s) | hisfm verdict | hisfm / colmap |\n"
        << "|---|---|---|---|---|---|---|\n";
      for (size_t i = 0; i < ns.size(); ++i) {
        t << "| " << ns[i] << " | " << pairs[i] << " | "
          << time_cell(c[i], fit, ns[i]) << " | " << c[i].verdict << " | "
          << time_cell(hisfm_runs[i], fit_hisfm, ns[i]) << " | "
          << hisfm_runs[i].verdict << " | "
          << ratio_cell(hisfm_runs[i], c[i], fit, ns[i]) << " |\n";
      }
      t << "\ncolmap's growth exponent (fit on " << fit.points
        << " finished size(s)): "
        << (fit.points >= 2 ? FormatFixed(fit.b, 2) : std::string("-"))
        << "\n";
      return t.str();
    };
    std::cout << "Scene `" << scene << "` (seed " << seed
              << (synth_args.empty() ? "" : ", " + synth_args)
              << "), budget " << FormatFixed(budget, 0)
              << " s per run; times in seconds.\n"
              << table("hisfm mapper against colmap mapper (defaults)",
                       colmap_default, fit_default)
              << table("hisfm mapper against colmap mapper with hisfm's "
                       "bundle-adjustment settings (" +
                           same_ba_text.substr(1) + ")",
                       colmap_same, fit_same)
              << "\nhisfm mapper's growth exponent: "
              << (fit_hisfm.points >= 2 ? FormatFixed(fit_hisfm.b, 2)
                                        : std::string("-"))
              << "\n";
  } catch (const Error& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
