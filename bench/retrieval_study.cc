// Retrieval matching (colmap vocab_tree_matcher with a tree built from the
// scene's own descriptors, as `hisfm reconstruct --matcher vocab_tree` does)
// against the exhaustive matching of the shared scenes' databases: for each
// scene and number of retrieved images per image, the share of all pairs
// matched, the recall of the pairs that exhaustive matching verifies with
// many inliers (--strong_inliers) and of each image's strongest pair (the
// hierarchy's community edges), matching time, and the verdict of `hisfm
// mapper` on both databases against the scene's reference (or registered
// images where it has none). Prints a Markdown table.
//
// With --synth_sizes, the same on synthetic scenes of those sizes
// (`--synth_scene`, default street), whose keypoints get SIFT-like
// descriptors: each appearance id of the scene (hisfm/synth/scene_layout.h:
// copies of repeated structure share one) draws a random descriptor, every
// observation adds noise of --descriptor_noise per byte, distractors draw
// their own. colmap then matches and verifies these keypoints itself; the
// exhaustive baseline is the generator's COLMAP-like verification of every
// pair (its database), and the verdict is against the ground truth.
//
//   build/bench/retrieval_study [--scenes yan2017/books,yan2017/cup,...]
//                               [--neighbors 5,10,20] [--strong_inliers 100]
//                               [--synth_sizes 100,1000] [--work_path DIR]
#include <CLI/CLI.hpp>
#include <algorithm>
#include <array>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <map>
#include <random>
#include <set>
#include <sstream>

#include "hisfm/eval/pose_evaluation.h"
#include "hisfm/io/database.h"
#include "hisfm/io/model.h"
#include "hisfm/io/sqlite_util.h"
#include "hisfm/recon/colmap_runner.h"
#include "hisfm/recon/feature_pipeline.h"
#include "hisfm/synth/synthetic_dataset.h"
#include "hisfm/synth/synthetic_scene.h"
#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"
#include "hisfm/util/string_util.h"
#include "hisfm/util/test_util.h"
#include "hisfm/util/timer.h"

namespace fs = std::filesystem;
using namespace hisfm;

namespace {

using PairKey = std::pair<ImageId, ImageId>;

std::map<PairKey, uint32_t> Inliers(const std::string& path) {
  Database db(path);
  std::map<PairKey, uint32_t> out;
  for (const VerifiedPair& p : db.ReadVerifiedPairs(1)) {
    out[{p.pair.image_id1, p.pair.image_id2}] = p.num_inliers;
  }
  return out;
}

// Pairs colmap tried (rows of the matches table).
size_t MatchedPairs(const std::string& path) {
  SqliteConnection db = OpenReadOnlyConnection(path);
  ThrowUnless(db != nullptr, "cannot open " + path);
  SqliteStatement q(db.get(), "SELECT count(*) FROM matches");
  return q.Step() ? static_cast<size_t>(sqlite3_column_int64(q.get(), 0)) : 0;
}

double MeanDescriptors(const std::string& path) {
  SqliteConnection db = OpenReadOnlyConnection(path);
  ThrowUnless(db != nullptr, "cannot open " + path);
  SqliteStatement q(db.get(), "SELECT avg(rows) FROM descriptors");
  return q.Step() ? sqlite3_column_double(q.get(), 0) : 0.0;
}

// "✓ 99.5%" against a reference, or "21/21 registered" without one.
std::string Verdict(const std::string& hisfm, const std::string& db,
                    const std::string& images, const std::string& out,
                    const std::string& reference, size_t num_images,
                    double* seconds) {
  Timer timer;
  const int code = RunShell(StrCat(hisfm, " mapper --database_path ", db,
                                   " --image_path ", images,
                                   " --output_path ", out,
                                   " --log_level warn"),
                            out + ".log");
  *seconds = timer.ElapsedSeconds();
  if (code != 0) return "failed";
  const std::vector<Reconstruction> models = ReadNumberedModels(out);
  if (models.empty()) return "×";
  if (reference.empty()) {
    size_t registered = 0;
    for (const Reconstruction& m : models) {
      registered = std::max(registered, m.NumRegImages());
    }
    return StrCat(registered, "/", num_images, " registered, ",
                  models.size(), " model(s)");
  }
  const MultiModelEvaluation e =
      EvaluateModels(models, ReadModel(reference), PoseEvaluationOptions());
  return StrCat(e.correct ? "✓ " : "× ",
                FormatFixed(100.0 * e.largest.verdict_pair_fraction, 1),
                "% ≤5°, ", e.largest.num_registered, "/", num_images,
                " reg., ", models.size(), " model(s)");
}

// Writes SIFT-like descriptors for every keypoint of the synthetic scene
// into its database (generated from the same options).
void WriteSyntheticDescriptors(const SyntheticScene& scene,
                               const std::string& path, double noise,
                               uint32_t seed) {
  auto base = [&](uint32_t appearance) {
    std::mt19937 rng(seed * 2654435761u + appearance);
    std::gamma_distribution<double> g(0.6, 25.0);
    std::array<double, 128> d{};
    for (double& v : d) v = std::min(255.0, g(rng));
    return d;
  };
  sqlite3* db = nullptr;
  ThrowUnless(sqlite3_open(path.c_str(), &db) == SQLITE_OK, "cannot open " + path);
  SqliteExec(db, "BEGIN; DELETE FROM descriptors;");
  {
    SqliteStatement insert(db, "INSERT INTO descriptors VALUES (?, ?, 128, ?)");
    std::mt19937 rng(seed);
    std::normal_distribution<double> n01(0.0, noise);
    for (const SynthImage& image : scene.images) {
      std::vector<uint8_t> data(image.features.size() * 128);
      for (size_t f = 0; f < image.features.size(); ++f) {
        const uint32_t p = image.features[f].point_index;
        const uint32_t appearance =
            p == kNoScenePoint ? 0x80000000u + static_cast<uint32_t>(rng() >> 1)
                               : scene.layout.points[p].appearance;
        std::array<double, 128> d = base(appearance);
        double norm = 0;
        for (double& v : d) {
          v = std::max(0.0, v + n01(rng));
          norm += v * v;
        }
        // COLMAP's byte descriptors are unit vectors times 512 (its matcher
        // takes acos of the dot product / 512^2 and keeps <= 0.7 rad): a
        // descriptor of another norm matches nothing.
        const double scale = norm > 0 ? 512.0 / std::sqrt(norm) : 0.0;
        for (int k = 0; k < 128; ++k) {
          data[f * 128 + k] = static_cast<uint8_t>(
              std::clamp(std::lround(d[k] * scale), 0L, 255L));
        }
      }
      sqlite3_bind_int64(insert.get(), 1, image.image_id);
      sqlite3_bind_int64(insert.get(), 2,
                         static_cast<sqlite3_int64>(image.features.size()));
      sqlite3_bind_blob(insert.get(), 3, data.data(),
                        static_cast<int>(data.size()), SQLITE_TRANSIENT);
      insert.Step();
      insert.Reset();
    }
  }
  SqliteExec(db, "COMMIT;");
  sqlite3_close(db);
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("Retrieval matching against exhaustive matching");
  std::string scenes_arg = "yan2017/books,yan2017/oats,yan2017/cup";
  std::string neighbors_arg = "5,10,20";
  std::string work_path = "/tmp/hisfm-retrieval";
  std::string hisfm = fs::path(argv[0]).parent_path().parent_path() / "hisfm";
  uint32_t strong = 100;
  std::string synth_sizes;
  std::string synth_scene = "street";
  double descriptor_noise = 6.0;
  app.add_option("--scenes", scenes_arg, "Scenes under HISFM_DATA_DIR")
      ->capture_default_str();
  app.add_option("--neighbors", neighbors_arg,
                 "Retrieved images per image (--num_neighbors)")
      ->capture_default_str();
  app.add_option("--strong_inliers", strong,
                 "Inliers of an exhaustive pair that retrieval must find")
      ->capture_default_str();
  app.add_option("--synth_sizes", synth_sizes,
                 "Also synthetic scenes of these sizes (e.g. 100,1000)");
  app.add_option("--synth_scene", synth_scene, "hisfm synth --scene")
      ->capture_default_str();
  app.add_option("--descriptor_noise", descriptor_noise,
                 "Synthetic descriptors: noise per byte (base values have a "
                 "mean of 15)")
      ->capture_default_str();
  app.add_option("--work_path", work_path, "Scratch folder (emptied)")
      ->capture_default_str();
  app.add_option("--hisfm", hisfm, "The hisfm executable")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  try {
    fs::remove_all(work_path);
    fs::create_directories(work_path);
    std::ostringstream table;
    table << "| scene | images | matcher | pairs matched | share of all "
             "pairs | recall ≥" << strong << " inliers | recall of top-1 "
             "pairs | tree (s) | matching (s) | hisfm verdict | mapper (s) "
             "|\n|---|---|---|---|---|---|---|---|---|---|---|\n";
    std::cout << table.str() << std::flush;
    size_t printed = table.str().size();
    struct Scene {
      std::string slug, source, features, images, reference;
    };
    std::vector<Scene> list;
    std::stringstream scenes(scenes_arg);
    std::string scene;
    while (std::getline(scenes, scene, ',')) {
      Scene sc;
      sc.source = SharedDataPath(scene, "database.db");
      ThrowUnless(!sc.source.empty(), "scene not found: " + scene);
      sc.images = SharedDataPath(scene, "images");
      sc.reference = SharedDataPath(scene, "reference");
      sc.slug = fs::path(scene).filename();
      list.push_back(sc);
    }
    std::stringstream sizes(synth_sizes);
    while (std::getline(sizes, scene, ',')) {
      SynthOptions options;
      options.scene = synth_scene;
      options.num_images = std::stoi(scene);
      options.seed = 1;
      Scene sc;
      sc.slug = StrCat(synth_scene, "_", options.num_images);
      const std::string dir = work_path + "/" + sc.slug + "/scene";
      std::cerr << "== generating " << sc.slug << "\n";
      WriteSyntheticDataset(options, dir);
      sc.source = dir + "/database.db";
      sc.images = dir;
      sc.reference = dir + "/ground_truth";
      // Features with descriptors, no matches: the retrieval input.
      sc.features = work_path + "/" + sc.slug + "/features.db";
      fs::copy_file(sc.source, sc.features);
      WriteSyntheticDescriptors(GenerateScene(options), sc.features,
                                descriptor_noise, 1);
      list.push_back(sc);
    }
    for (const Scene& sc : list) {
      const std::string& source = sc.source;
      const std::string& images = sc.images;
      const std::string& reference = sc.reference;
      const std::string& slug = sc.slug;
      const std::string dir = work_path + "/" + slug;
      fs::create_directories(dir);
      std::cerr << "== " << slug << "\n";
      const std::map<PairKey, uint32_t> exhaustive = Inliers(source);
      size_t n = 0;
      {
        Database db(source);
        n = db.ReadImages().size();
      }
      const size_t all_pairs = n * (n - 1) / 2;
      std::set<PairKey> strong_pairs, top1;
      std::map<ImageId, std::pair<uint32_t, PairKey>> best;
      for (const auto& [pair, inliers] : exhaustive) {
        if (inliers >= strong) strong_pairs.insert(pair);
        for (ImageId id : {pair.first, pair.second}) {
          if (inliers > best[id].first) best[id] = {inliers, pair};
        }
      }
      for (const auto& [id, b] : best) top1.insert(b.second);
      double seconds = 0;
      const std::string exhaustive_verdict =
          Verdict(hisfm, source, images, dir + "/exhaustive", reference, n,
                  &seconds);
      table << "| " << slug << " | " << n << " | exhaustive ("
            << (sc.features.empty() ? "colmap" : "generator") << ") | "
            << MatchedPairs(source) << " | 100% | 100% | "
            << "100% | - | - | " << exhaustive_verdict << " | "
            << FormatFixed(seconds, 1) << " |\n";
      // Features only, then the tree of hisfm reconstruct's defaults.
      const std::string features =
          sc.features.empty() ? dir + "/features.db" : sc.features;
      if (sc.features.empty()) fs::copy_file(source, features);
      {
        sqlite3* db = nullptr;
        sqlite3_open(features.c_str(), &db);
        SqliteExec(db,
                   "DELETE FROM matches; DELETE FROM two_view_geometries;");
        sqlite3_close(db);
      }
      FeaturePipelineOptions defaults;
      const int words = VocabTreeBuildWords(defaults, n);
      const std::string tree = dir + "/vocab_tree.bin";
      ColmapRunnerOptions colmap;
      const double tree_seconds = RunColmap(
          colmap,
          {"vocab_tree_builder", "--database_path", features,
           "--vocab_tree_path", tree, "--num_visual_words",
           std::to_string(words), "--branching",
           std::to_string(VocabTreeBuildBranching(words)), "--num_iterations",
           "5", "--max_num_images",
           std::to_string(VocabTreeBuildImages(n, MeanDescriptors(features)))},
          dir + "/vocab_tree_builder.log");
      std::stringstream ks(neighbors_arg);
      std::string k;
      while (std::getline(ks, k, ',')) {
        const std::string db = dir + "/vocab_" + k + ".db";
        fs::copy_file(features, db);
        const double match_seconds = RunColmap(
            colmap,
            {"vocab_tree_matcher", "--database_path", db,
             "--VocabTreeMatching.vocab_tree_path", tree,
             "--VocabTreeMatching.num_images", k, "--SiftMatching.use_gpu",
             "0"},
            dir + "/vocab_" + k + ".log");
        const std::map<PairKey, uint32_t> found = Inliers(db);
        const size_t matched = MatchedPairs(db);
        auto recall = [&](const std::set<PairKey>& wanted) {
          size_t hit = 0;
          for (const PairKey& p : wanted) hit += found.count(p);
          return wanted.empty() ? std::string("-")
                                : FormatFixed(100.0 * hit / wanted.size(), 1) +
                                      "%";
        };
        const std::string verdict = Verdict(
            hisfm, db, images, dir + "/hisfm_" + k, reference, n, &seconds);
        table << "| " << slug << " | " << n << " | vocab_tree, " << k
              << " neighbours, " << words << " words | " << matched << " | "
              << FormatFixed(100.0 * matched / std::max<size_t>(all_pairs, 1),
                             1)
              << "% | " << recall(strong_pairs) << " | " << recall(top1)
              << " | " << FormatFixed(tree_seconds, 1) << " | "
              << FormatFixed(match_seconds, 1) << " | " << verdict << " | "
              << FormatFixed(seconds, 1) << " |\n";
        std::cout << table.str().substr(printed) << std::flush;
        printed = table.str().size();
      }
    }
    std::cout << "\n" << table.str();
  } catch (const Error& e) {
    std::cerr << "error: " << e.what() << "\n";
    return 1;
  }
  return 0;
}
