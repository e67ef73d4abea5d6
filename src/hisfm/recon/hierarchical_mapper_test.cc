#include "hisfm/recon/hierarchical_mapper.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <set>

#include "hisfm/io/database.h"
#include "hisfm/io/database_writer.h"
#include "hisfm/eval/pose_evaluation.h"
#include "hisfm/io/model.h"
#include "hisfm/recon/colmap_runner.h"
#include "hisfm/recon/exhaustive_filter.h"
#include "hisfm/synth/synthetic_dataset.h"
#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"
#include "hisfm/util/string_util.h"
#include "hisfm/util/test_util.h"

namespace fs = std::filesystem;

namespace hisfm {
namespace {

std::string ErrorOf(const MapperPaths& paths,
                    const HierarchicalMapperOptions& options) {
  try {
    RunHierarchicalMapper(paths, options);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

MapperPaths CupPaths(const TempDir& tmp) {
  MapperPaths p;
  p.database_path = SharedDataPath("yan2017/cup", "database.db");
  p.image_path = SharedDataPath("yan2017/cup", "images");
  p.output_path = tmp / "out";
  return p;
}

TEST(HierarchicalMapperOptions, MergeAndJoinNeedTheirOwnAgreementShares) {
  // The merge through shared images needs 70% of the shared points to
  // agree (measured, model_merge.h); the join through matches keeps 0.5.
  const HierarchicalMapperOptions options;
  EXPECT_EQ(options.merge.min_inlier_ratio, 0.7);
  EXPECT_EQ(options.join.min_inlier_ratio, 0.5);
  EXPECT_EQ(options.join.min_inliers, ModelMergeOptions().min_inliers);
  options.Check();
}

TEST(HierarchicalMapper, BadInputGivesOneLineErrorsAndWritesNothing) {
  TempDir tmp;
  HierarchicalMapperOptions options;
  options.verifier.verifier = "none";
  MapperPaths paths;
  paths.database_path = tmp / "missing.db";
  paths.image_path = tmp.path();
  paths.output_path = tmp / "out";
  EXPECT_NE(ErrorOf(paths, options).find("does not exist"), std::string::npos);

  // A database without verified pairs.
  {
    DatabaseWriter w(tmp / "empty.db");
    w.WriteCamera(SimplePinholeCamera(1, 100, 100, 100));
    w.WriteImage({1, "a.jpg", 1});
    w.WriteImage({2, "b.jpg", 1});
  }
  paths.database_path = tmp / "empty.db";
  const std::string no_pairs = ErrorOf(paths, options);
  EXPECT_NE(no_pairs.find("no verified image pairs"), std::string::npos)
      << no_pairs;
  EXPECT_EQ(no_pairs.find('\n'), std::string::npos);
  EXPECT_FALSE(fs::exists(tmp / "out") && !fs::is_empty(tmp / "out"));

  paths.image_path = tmp / "no_such_folder";
  EXPECT_NE(ErrorOf(paths, options).find("image folder"), std::string::npos);

  // A non-empty output folder is refused and left as it was.
  paths.image_path = tmp.path();
  fs::create_directories(tmp / "full");
  std::ofstream(tmp / "full/keep.txt") << "x";
  paths.output_path = tmp / "full";
  EXPECT_NE(ErrorOf(paths, options).find("not empty"), std::string::npos);
  EXPECT_TRUE(fs::exists(tmp / "full/keep.txt"));

  // colmap missing.
  paths.output_path = tmp / "out2";
  options.colmap.colmap_path = "/nonexistent/colmap";
  paths.database_path = tmp / "empty.db";
  EXPECT_NE(ErrorOf(paths, options).find("colmap not found"),
            std::string::npos);
  EXPECT_FALSE(fs::exists(tmp / "out2"));
}

TEST(HierarchicalMapper, FailingColmapReportsCommandAndLog) {
  const std::string db = SharedDataPath("yan2017/cup", "database.db");
  if (db.empty()) GTEST_SKIP() << "shared data not found: " << SharedDataDir();
  if (!ColmapAvailable()) GTEST_SKIP() << "colmap is not installed";
  TempDir tmp;
  MapperPaths paths = CupPaths(tmp);
  HierarchicalMapperOptions options;
  options.verifier.verifier = "none";
  options.mapper_args = {"--Mapper.no_such_option", "1"};
  const std::string error = ErrorOf(paths, options);
  EXPECT_NE(error.find("colmap failed"), std::string::npos) << error;
  EXPECT_NE(error.find("mapper --database_path"), std::string::npos) << error;
  EXPECT_FALSE(fs::exists(paths.output_path));
}

TEST(HierarchicalMapper, RegistersAllCupImages) {
  const std::string db = SharedDataPath("yan2017/cup", "database.db");
  if (db.empty()) GTEST_SKIP() << "shared data not found: " << SharedDataDir();
  if (!ColmapAvailable()) GTEST_SKIP() << "colmap is not installed";
  TempDir tmp;
  const uint64_t before = FileFingerprint(db);
  MapperPaths paths = CupPaths(tmp);
  paths.options_record = "HiSfM.top_k=1\n";
  HierarchicalMapperOptions options;
  options.verifier.verifier = "none";
  const nlohmann::json summary = RunHierarchicalMapper(paths, options);
  EXPECT_EQ(FileFingerprint(db), before) << "the input database changed";
  EXPECT_EQ(summary["images"], 64);
  EXPECT_EQ(summary["verified_pairs"], 2016);
  EXPECT_EQ(summary["registered_images"], 64);
  EXPECT_LT(summary["skeleton_images"].get<int>(), 64);
  EXPECT_LT(summary["hierarchy_edges"].get<int>(), 2016 / 10);
  EXPECT_GT(summary["points3D"].get<int>(), 1000);
  EXPECT_LT(summary["mean_reprojection_error"].get<double>(), 2.0);
  const Reconstruction model = ReadModel(paths.output_path + "/0");
  EXPECT_EQ(model.NumRegImages(), 64u);
  EXPECT_TRUE(fs::exists(paths.output_path + "/hisfm_summary.json"));
  EXPECT_TRUE(fs::exists(paths.output_path + "/hisfm_options.ini"));
  EXPECT_TRUE(fs::exists(paths.output_path + "_work/view_graph.json"));
  // Only the skeleton's pairs went into the scaffold database.
  Database skeleton(paths.output_path + "_work/component0/skeleton.db");
  EXPECT_EQ(skeleton.NumVerifiedPairs(),
            summary["skeleton_edges"].get<size_t>());
}

// The pipeline with the default (builtin) verifier on a shared scene where
// vanilla COLMAP folds: every image registered, at least 95% of the pairs
// within 5 degrees of the reference and of the camera centres within 5% of
// the scene extent. `summary`, if given, gets the run's summary.
void ExpectCorrect(
    const std::string& scene, size_t num_images,
    const std::string& reference_dir = "reference",
    const HierarchicalMapperOptions& options = HierarchicalMapperOptions(),
    nlohmann::json* summary_out = nullptr) {
  const std::string db = SharedDataPath(scene, "database.db");
  if (db.empty()) GTEST_SKIP() << "shared data not found: " << SharedDataDir();
  if (!ColmapAvailable()) GTEST_SKIP() << "colmap is not installed";
  TempDir tmp;
  MapperPaths paths;
  paths.database_path = db;
  // Scenes without photos (synthetic correspondences) have no images/.
  paths.image_path = SharedDataPath(scene, "images");
  if (paths.image_path.empty()) paths.image_path = SharedDataPath(scene, "");
  paths.output_path = tmp / "out";
  const nlohmann::json summary = RunHierarchicalMapper(paths, options);
  if (summary_out != nullptr) *summary_out = summary;
  // After the sequence pass its kept pairs need no verifier
  // (trust_sequence_checks); some pair was judged either way.
  EXPECT_GT(summary["verification"]["pairs_evaluated"].get<int>() +
                summary["verification"].value("pairs_pre_verified", 0),
            0)
      << "no pair was judged, by the verifier or the sequence pass";
  EXPECT_LT(summary["verified_fraction"].get<double>(), 0.25);
  const Reconstruction reference =
      ReadModel(SharedDataPath(scene, reference_dir));
  const PoseEvaluation e = EvaluateModel(ReadModel(paths.output_path + "/0"),
                                         reference, PoseEvaluationOptions());
  EXPECT_EQ(e.num_registered, num_images);
  EXPECT_GE(e.verdict_pair_fraction, 0.95);
  EXPECT_LT(e.median_rotation_error_deg, 2.0);
  EXPECT_LT(e.median_translation_error_deg, 2.0);
  EXPECT_TRUE(e.correct) << e.verdict_reason;
  EXPECT_FALSE(fs::exists(paths.output_path + "/1")) << "one model expected";
}

TEST(HierarchicalMapper, CupIsCorrectWhereColmapFolds) {
  ExpectCorrect("yan2017/cup", 64);
}

// At the paper's tau = 0.8 the builtin scores cup's strong true bridges
// between its two halves 0.70 to 0.80 and weak doppelgangers above 0.8;
// the near-miss vote (SkeletonOptions::near_miss_vote) refuses those.
// At tau = 0.8 the first tree cannot span with bridges that pass; within
// its verification budget it leaves the rest to the fallback threshold.
TEST(HierarchicalMapper, CupIsCorrectAtThePapersTau) {
  HierarchicalMapperOptions options;
  options.hierarchy.skeleton.verify_threshold = 0.8;
  nlohmann::json summary;
  ExpectCorrect("yan2017/cup", 64, "reference", options, &summary);
  if (!summary.is_null()) {
    // Issue 12's bound: verifier calls within 5% of the verified pairs.
    EXPECT_LE(summary["verifier_calls"].get<double>(),
              0.05 * summary["verified_pairs"].get<double>());
  }
}

// Without the budget Algorithm 1's first tree scans on and meets weak
// doppelgangers above tau; the near-miss vote refuses them.
TEST(HierarchicalMapper, CupIsCorrectAtThePapersTauWithoutABudget) {
  HierarchicalMapperOptions options;
  // The sequence pass removes those doppelgangers before the skeleton
  // meets them: off, so that the vote is what is tested.
  options.sequence.sequence.mode = "off";
  options.hierarchy.skeleton.verify_threshold = 0.8;
  options.hierarchy.skeleton.first_tree_budget_trees = 0;
  nlohmann::json summary;
  ExpectCorrect("yan2017/cup", 64, "reference", options, &summary);
  if (!summary.is_null()) {
    EXPECT_GT(summary["outvoted_bridges"].get<int>(), 0);
  }
}

// Oats: two identical cereal boxes; no published method reconstructs it
// correctly, and vanilla colmap folds it (47.8% of pairs within 5 degrees).
// Its reference, as issue 12 defines it, is colmap's reconstruction from the
// pairs at most 2 apart in name order (no pair across the boxes), built here.
// The names are the capture order, and the sequence pass makes the mapper
// agree with it.
TEST(HierarchicalMapper, OatsAgreesWithItsConsecutivePhotos) {
  const std::string db = SharedDataPath("yan2017/oats", "database.db");
  if (db.empty()) GTEST_SKIP() << "shared data not found: " << SharedDataDir();
  if (!ColmapAvailable()) GTEST_SKIP() << "colmap is not installed";
  TempDir tmp;
  std::vector<ImagePair> near;
  {
    const Database input(db);
    std::vector<DatabaseImage> images = input.ReadImages();
    std::sort(images.begin(), images.end(),
              [](const DatabaseImage& a, const DatabaseImage& b) {
                return a.name < b.name;
              });
    std::map<ImageId, int> place;
    for (size_t k = 0; k < images.size(); ++k) {
      place[images[k].image_id] = static_cast<int>(k);
    }
    for (const VerifiedPair& p : input.ReadVerifiedPairs(15)) {
      if (std::abs(place[p.pair.image_id1] - place[p.pair.image_id2]) <= 2) {
        near.push_back(p.pair);
      }
    }
  }
  WriteFilteredDatabase(db, tmp / "near.db", near);
  fs::create_directories(tmp / "reference");
  const std::string image_path = SharedDataPath("yan2017/oats", "images");
  RunColmap(ColmapRunnerOptions(),
            {"mapper", "--database_path", tmp / "near.db", "--image_path",
             image_path, "--output_path", tmp / "reference"},
            tmp / "reference.log");
  const Reconstruction reference = ReadModel(tmp / "reference/0");
  ASSERT_EQ(reference.NumRegImages(), 23u);

  MapperPaths paths;
  paths.database_path = db;
  paths.image_path = image_path;
  paths.output_path = tmp / "out";
  const nlohmann::json summary =
      RunHierarchicalMapper(paths, HierarchicalMapperOptions());
  EXPECT_TRUE(summary["sequence"]["ran"]);
  const PoseEvaluation e =
      EvaluateModel(ReadModel(tmp / "out/0"), reference, {});
  EXPECT_EQ(e.num_registered, 23u);
  EXPECT_TRUE(e.correct) << e.verdict_reason;
}

TEST(HierarchicalMapper, BooksIsCorrectWhereColmapFolds) {
  ExpectCorrect("yan2017/books", 21);
}

// The repeated planar facade of issue 12 (vanilla colmap: 37% of pairs
// within 5 degrees).
TEST(HierarchicalMapper, FacadeStreet60IsCorrectWhereColmapFolds) {
  ExpectCorrect("synthetic/facade_street_60", 60, "ground_truth");
}

// The colmap commands of the component's log that start with `prefix`.
std::vector<std::string> ColmapCommands(const std::string& component,
                                        const std::string& prefix) {
  std::ifstream log(component + "/colmap.log");
  std::vector<std::string> out;
  for (std::string line; std::getline(log, line);) {
    if (line.rfind(prefix, 0) == 0) out.push_back(line + " ");
  }
  return out;
}

// Writes the synthetic scene `scene` (num_images, seed; a family's
// parameters drawn from the seed if `randomize_family`) to tmp/scene; the
// mapper's paths for it, output to tmp/out.
MapperPaths SynthScene(const TempDir& tmp, const std::string& scene,
                       int num_images, uint32_t seed,
                       bool randomize_family = false) {
  SynthOptions synth;
  synth.scene = scene;
  synth.num_images = num_images;
  synth.seed = seed;
  synth.family.randomize = randomize_family;
  WriteSyntheticDataset(synth, tmp / "scene");
  MapperPaths paths;
  paths.database_path = tmp / "scene/database.db";
  paths.image_path = tmp / "scene/images";
  paths.output_path = tmp / "out";
  return paths;
}

// `paths` with the output in tmp/NAME and the work folder in tmp/NAME_work.
MapperPaths OtherOutput(const MapperPaths& paths, const TempDir& tmp,
                        const std::string& name) {
  MapperPaths other = paths;
  other.output_path = tmp / name;
  other.work_path = tmp / (name + "_work");
  return other;
}

// The model tmp/MODEL registers the synthetic scene's `num_images` images
// (SynthScene) and is correct against its ground truth.
void ExpectSceneCorrect(const TempDir& tmp, const std::string& model,
                        size_t num_images) {
  const PoseEvaluation e = EvaluateModel(
      ReadModel(tmp / model), ReadModel(tmp / "scene/ground_truth"), {});
  EXPECT_EQ(e.num_registered, num_images);
  EXPECT_TRUE(e.correct) << e.verdict_reason;
}

// The scaffold's bundle adjustment schedule and the global tolerance reach
// colmap; an explicit --Mapper flag replaces HiSfM's default instead of
// being repeated; the result stays correct on a synthetic ring.
TEST(HierarchicalMapper, BundleAdjustmentScheduleReachesColmap) {
  if (!ColmapAvailable()) GTEST_SKIP() << "colmap is not installed";
  TempDir tmp;
  const MapperPaths paths = SynthScene(tmp, "symmetric2", 24, 1);
  HierarchicalMapperOptions options;
  options.scaffold_ba_global_ratio = 1.5;
  options.ba_local_max_refinements = 3;
  options.scaffold_ba_global_max_refinements = 3;
  options.mapper_args = {"--Mapper.ba_global_function_tolerance", "1e-09"};
  // A scaffold run of colmap mapper, not the sequence pass's chain.
  options.scaffold_from_sequence_chain = false;
  RunHierarchicalMapper(paths, options);
  std::ifstream log(tmp / "out_work/component0/colmap.log");
  std::vector<std::string> commands;
  for (std::string line; std::getline(log, line);) {
    if (line.rfind("$ colmap mapper", 0) == 0) commands.push_back(line + " ");
  }
  ASSERT_EQ(commands.size(), 2u) << "scaffold and attach";
  const std::string& scaffold = commands[0];
  const std::string& attach = commands[1];
  EXPECT_NE(scaffold.find("--Mapper.ba_global_images_ratio 1.5 "),
            std::string::npos) << scaffold;
  EXPECT_NE(scaffold.find("--Mapper.ba_global_points_ratio 1.5 "),
            std::string::npos) << scaffold;
  EXPECT_NE(scaffold.find("--Mapper.ba_global_max_refinements 3 "),
            std::string::npos) << scaffold;
  for (const std::string& c : commands) {
    EXPECT_EQ(CountOccurrences(c, "--Mapper.ba_global_function_tolerance"), 1u)
        << c;
    EXPECT_NE(c.find("--Mapper.ba_global_function_tolerance 1e-09 "),
              std::string::npos) << c;
    EXPECT_NE(c.find("--Mapper.ba_local_max_refinements 3 "),
              std::string::npos) << c;
  }
  // The attach run keeps its own schedule: global adjustment only at the end.
  EXPECT_NE(attach.find("--Mapper.ba_global_images_ratio 1000000 "),
            std::string::npos) << attach;
  // No extra bundle adjustment unless asked for: no refined/ folder.
  EXPECT_FALSE(fs::exists(tmp / "out_work/component0/refined"));
  const PoseEvaluation e =
      EvaluateModel(ReadModel(tmp / "out/0"),
                    ReadModel(tmp / "scene/ground_truth"), {});
  EXPECT_EQ(e.num_registered, 24u);
  EXPECT_TRUE(e.correct) << e.verdict_reason;

  options.scaffold_ba_global_ratio = 0.9;
  EXPECT_NE(ErrorOf(paths, options).find("scaffold_ba_global_ratio"),
            std::string::npos);
  options.scaffold_ba_global_ratio = 1.4;
  options.ba_global_function_tolerance = -1;
  EXPECT_NE(ErrorOf(paths, options).find("ba_global_function_tolerance"),
            std::string::npos);
}

// A scaffold larger than scaffold_segment_images is reconstructed in
// overlapping segments, one colmap run each, merged into one scaffold
// through their shared images; the result is correct against the truth.
TEST(HierarchicalMapper, ALargeScaffoldIsReconstructedInSegmentsThatMerge) {
  if (!ColmapAvailable()) GTEST_SKIP() << "colmap is not installed";
  TempDir tmp;
  const MapperPaths paths = SynthScene(tmp, "street_control", 60, 2);
  HierarchicalMapperOptions options;
  options.sequence.sequence.mode = "off";
  options.scaffold_segment_images = 20;
  options.scaffold_segment_overlap = 8;
  const nlohmann::json summary = RunHierarchicalMapper(paths, options);
  const nlohmann::json& model = summary["models"][0];
  const size_t scaffold_images = model["scaffold_images"].get<size_t>();
  ASSERT_GT(scaffold_images, 20u) << "the scaffold fits one segment";
  const size_t segments = model["scaffold_segments"].get<size_t>();
  EXPECT_GE(segments, 2u);
  EXPECT_FALSE(model["scaffold_fallback"].get<bool>());
  // Every segment's model but the base was merged into it.
  EXPECT_GE(model["scaffold_merged_sub_models"].get<size_t>(), segments - 1);
  EXPECT_GE(model["scaffold_registered"].get<size_t>(),
            scaffold_images * 9 / 10);
  std::ifstream log(tmp / "out_work/component0/colmap.log");
  size_t scaffold_runs = 0;
  for (std::string line; std::getline(log, line);) {
    if (line.rfind("$ colmap mapper", 0) == 0 &&
        line.find("skeleton_images_") != std::string::npos) {
      ++scaffold_runs;
    }
  }
  EXPECT_EQ(scaffold_runs, segments);
  // Without the sequence pass no pair outside the skeleton was checked:
  // the segments are merged unrefined.
  EXPECT_TRUE(
      ColmapCommands(tmp / "out_work/component0", "$ colmap point_triangulator")
          .empty());
  ExpectSceneCorrect(tmp, "out/0", 60);

  // Segments need their merge: without it the scaffold is one run.
  MapperPaths unmerged = paths;
  unmerged.output_path = tmp / "unmerged";
  HierarchicalMapperOptions no_merge = options;
  no_merge.merge_sub_models = false;
  EXPECT_EQ(RunHierarchicalMapper(unmerged,
                                  no_merge)["models"][0]["scaffold_segments"]
                .get<size_t>(),
            1u);

  options.scaffold_segment_overlap = 20;
  EXPECT_NE(ErrorOf(paths, options).find("scaffold_segment_overlap"),
            std::string::npos);
}

// --HiSfM.refine_with_sequence_pairs: after the sequence pass, each scaffold
// segment is re-triangulated from the pass's checked pairs and adjusted
// before the merge, which reads the refined folders; the street stays
// correct. Off, or without the pass, no segment is refined.
TEST(HierarchicalMapper, ScaffoldSegmentsAreRefinedFromTheSequencesPairs) {
  if (!ColmapAvailable()) GTEST_SKIP() << "colmap is not installed";
  TempDir tmp;
  const MapperPaths paths = SynthScene(tmp, "street_control", 60, 2);
  HierarchicalMapperOptions options;
  options.scaffold_segment_images = 20;
  options.scaffold_segment_overlap = 8;
  // The scaffold is reconstructed, not taken from the chain.
  options.scaffold_from_sequence_chain = false;
  const nlohmann::json summary = RunHierarchicalMapper(paths, options);
  ASSERT_TRUE(summary["sequence"]["ran"].get<bool>());
  EXPECT_FALSE(summary["models"][0]["scaffold_from_chain"].get<bool>());
  const size_t segments =
      summary["models"][0]["scaffold_segments"].get<size_t>();
  ASSERT_GE(segments, 2u);
  const std::string component = tmp / "out_work/component0";
  const std::vector<std::string> triangulators =
      ColmapCommands(component, "$ colmap point_triangulator");
  const std::vector<std::string> adjusters =
      ColmapCommands(component, "$ colmap bundle_adjuster");
  EXPECT_GE(triangulators.size(), segments);
  EXPECT_EQ(adjusters.size(), triangulators.size());
  for (const std::string& line : triangulators) {
    EXPECT_NE(line.find("_refined.db "), std::string::npos) << line;
  }
  EXPECT_TRUE(fs::exists(component + "/scaffold/segment0_refined/0"));
  // The refined segments carry more tracks than the skeleton's edges give.
  const Reconstruction raw =
      ReadModelBinary(component + "/scaffold/segment1/0");
  const Reconstruction refined =
      ReadModelBinary(component + "/scaffold/segment1_refined/0");
  EXPECT_EQ(refined.NumRegImages(), raw.NumRegImages());
  EXPECT_GT(refined.NumObservations(), raw.NumObservations());
  EXPECT_GT(summary["timings"]["retriangulation"].get<double>(), 0);
  // The attach run from the refined scaffold caps its global adjustment.
  const std::string attach_input =
      "--input_path " + component + "/scaffold/merged ";
  const std::string capped = "--Mapper.ba_global_max_num_iterations 10 ";
  size_t attach_runs = 0;
  for (const std::string& line : ColmapCommands(component, "$ colmap mapper")) {
    if (line.find(attach_input) == std::string::npos) continue;
    ++attach_runs;
    EXPECT_NE(line.find(capped), std::string::npos) << line;
  }
  EXPECT_EQ(attach_runs, 1u);
  ExpectSceneCorrect(tmp, "out/0", 60);

  const MapperPaths off = OtherOutput(paths, tmp, "off");
  HierarchicalMapperOptions no_refinement = options;
  no_refinement.refine_with_sequence_pairs = false;
  RunHierarchicalMapper(off, no_refinement);
  EXPECT_TRUE(
      ColmapCommands(tmp / "off_work/component0", "$ colmap point_triangulator")
          .empty());
  for (const std::string& line :
       ColmapCommands(tmp / "off_work/component0", "$ colmap mapper")) {
    EXPECT_EQ(line.find(capped), std::string::npos) << line;
  }
  no_refinement.refined_attach_ba_global_max_num_iterations = -1;
  EXPECT_NE(ErrorOf(off, no_refinement)
                .find("refined_attach_ba_global_max_num_iterations"),
            std::string::npos);
}

// --HiSfM.scaffold_from_sequence_chain and --HiSfM.trust_sequence_checks:
// after the sequence pass the scaffold is the chain's model without the
// leaves, re-triangulated and adjusted (no colmap mapper run on the
// skeleton), the leaves are attached to it on the hierarchy's edges, and
// the pairs the pass kept are not asked of the verifier; the street is
// correct. Off, the scaffold is reconstructed and the verifier judges them.
TEST(HierarchicalMapper, ScaffoldStartsFromTheSequencesChain) {
  if (!ColmapAvailable()) GTEST_SKIP() << "colmap is not installed";
  TempDir tmp;
  const MapperPaths paths = SynthScene(tmp, "street_control", 60, 2);
  const nlohmann::json summary = RunHierarchicalMapper(paths, {});
  ASSERT_TRUE(summary["sequence"]["ran"].get<bool>());
  const nlohmann::json& model = summary["models"][0];
  EXPECT_TRUE(model["scaffold_from_chain"].get<bool>());
  const std::string component = tmp / "out_work/component0";
  const Reconstruction scaffold =
      ReadModelBinary(component + "/scaffold_refined/0");
  EXPECT_EQ(scaffold.NumRegImages(), model["scaffold_images"].get<size_t>());
  EXPECT_LT(scaffold.NumRegImages(), 60u) << "the leaves are attached later";
  // One colmap mapper run, the attach run from the refined chain, capped.
  const std::vector<std::string> mappers =
      ColmapCommands(component, "$ colmap mapper");
  ASSERT_EQ(mappers.size(), 1u);
  EXPECT_NE(
      mappers[0].find("--input_path " + component + "/scaffold_refined/0 "),
      std::string::npos)
      << mappers[0];
  EXPECT_NE(mappers[0].find("--Mapper.ba_global_max_num_iterations 10 "),
            std::string::npos)
      << mappers[0];
  EXPECT_EQ(ColmapCommands(component, "$ colmap point_triangulator").size(),
            1u);
  // Its adjustment stops at the global adjustments' tolerance.
  const std::vector<std::string> adjusters =
      ColmapCommands(component, "$ colmap bundle_adjuster");
  ASSERT_EQ(adjusters.size(), 1u);
  EXPECT_NE(adjusters[0].find("--BundleAdjustment.function_tolerance 1e-07 "),
            std::string::npos)
      << adjusters[0];
  const size_t trusted =
      summary["verification"]["pairs_pre_verified"].get<size_t>();
  EXPECT_GT(trusted, 0u);
  ExpectSceneCorrect(tmp, "out/0", 60);

  const MapperPaths off = OtherOutput(paths, tmp, "off");
  HierarchicalMapperOptions options;
  options.scaffold_from_sequence_chain = false;
  options.trust_sequence_checks = false;
  const nlohmann::json off_summary = RunHierarchicalMapper(off, options);
  EXPECT_FALSE(off_summary["models"][0]["scaffold_from_chain"].get<bool>());
  EXPECT_EQ(
      ColmapCommands(tmp / "off_work/component0", "$ colmap mapper").size(),
      2u);
  EXPECT_FALSE(off_summary["verification"].contains("pairs_pre_verified"));
  EXPECT_GT(off_summary["verification"]["pairs_evaluated"].get<size_t>(),
            summary["verification"]["pairs_evaluated"].get<size_t>());

  // A chain longer than a scaffold segment is cut, refined and merged as
  // reconstructed segments are.
  const MapperPaths cut = OtherOutput(paths, tmp, "cut");
  HierarchicalMapperOptions segmented;
  segmented.scaffold_segment_images = 20;
  segmented.scaffold_segment_overlap = 8;
  const nlohmann::json cut_summary = RunHierarchicalMapper(cut, segmented);
  const nlohmann::json& cut_model = cut_summary["models"][0];
  EXPECT_TRUE(cut_model["scaffold_from_chain"].get<bool>());
  const size_t segments = cut_model["scaffold_segments"].get<size_t>();
  EXPECT_GE(segments, 2u);
  const std::string cut_component = tmp / "cut_work/component0";
  EXPECT_EQ(ColmapCommands(cut_component, "$ colmap point_triangulator").size(),
            segments);
  const std::vector<std::string> cut_mappers =
      ColmapCommands(cut_component, "$ colmap mapper");
  ASSERT_EQ(cut_mappers.size(), 1u);
  EXPECT_NE(cut_mappers[0].find("--input_path " + cut_component +
                                "/scaffold/merged "),
            std::string::npos)
      << cut_mappers[0];
  ExpectSceneCorrect(tmp, "cut/0", 60);
}

// --HiSfM.global_bundle_adjustment: one colmap bundle_adjuster on the
// attached model, whose output (refined/) is the component's model.
TEST(HierarchicalMapper, GlobalBundleAdjustmentRefinesTheAttachedModel) {
  if (!ColmapAvailable()) GTEST_SKIP() << "colmap is not installed";
  TempDir tmp;
  const MapperPaths paths = SynthScene(tmp, "object_control", 16, 3);
  HierarchicalMapperOptions options;
  options.global_bundle_adjustment = true;
  // No refinement of the sequence pass's chain before it.
  options.scaffold_from_sequence_chain = false;
  const nlohmann::json summary = RunHierarchicalMapper(paths, options);
  const std::string component = tmp / "out_work/component0";
  std::ifstream log(component + "/colmap.log");
  std::vector<std::string> adjusters;
  for (std::string line; std::getline(log, line);) {
    if (line.rfind("$ colmap bundle_adjuster", 0) == 0) {
      adjusters.push_back(line + " ");
    }
  }
  ASSERT_EQ(adjusters.size(), 1u);
  EXPECT_NE(adjusters[0].find("--input_path " + component + "/attached "),
            std::string::npos)
      << adjusters[0];
  EXPECT_NE(adjusters[0].find("--output_path " + component + "/refined "),
            std::string::npos)
      << adjusters[0];
  ASSERT_TRUE(fs::exists(component + "/refined/images.bin"));
  EXPECT_GT(summary["timings"]["global_bundle_adjustment"].get<double>(), 0);
  const Reconstruction refined = ReadModel(component + "/refined");
  const Reconstruction out = ReadModel(tmp / "out/0");
  EXPECT_EQ(out.NumRegImages(), refined.NumRegImages());
  EXPECT_EQ(out.NumRegImages(), 16u);
  const PoseEvaluation e =
      EvaluateModel(out, ReadModel(tmp / "scene/ground_truth"), {});
  EXPECT_TRUE(e.correct) << e.verdict_reason;
}

// Two unrelated synthetic scenes in one database: one model per connected
// component, each correct against its own ground truth; an image without any
// pair is reported, not registered.
TEST(HierarchicalMapper, DisconnectedDatabaseGivesOneModelPerComponent) {
  if (!ColmapAvailable()) GTEST_SKIP() << "colmap is not installed";
  TempDir tmp;
  SynthOptions a;
  a.scene = "object_control";
  a.num_images = 16;
  a.seed = 3;
  SynthOptions b = a;
  b.scene = "street_control";
  b.num_images = 12;
  WriteSyntheticDataset(a, tmp / "a");
  WriteSyntheticDataset(b, tmp / "b");
  // Merge: scene b's images get ids after a's and a name prefix.
  const ImageId offset = 1000;
  {
    DatabaseWriter w(tmp / "merged.db");
    Database da(tmp / "a/database.db"), db(tmp / "b/database.db");
    DatabaseCamera cam = da.ReadCameras()[0];
    w.WriteCamera(cam);
    for (const DatabaseImage& im : da.ReadImages()) {
      w.WriteImage(im);
      w.WriteKeypoints(im.image_id, da.ReadKeypoints(im.image_id));
    }
    for (DatabaseImage im : db.ReadImages()) {
      const ImageId old = im.image_id;
      im.image_id += offset;
      im.name = "b_" + im.name;
      w.WriteImage(im);
      w.WriteKeypoints(im.image_id, db.ReadKeypoints(old));
    }
    w.WriteImage({5000, "lonely.png", cam.camera_id});
    for (const VerifiedPair& p : da.ReadVerifiedPairs(1)) {
      w.WriteTwoViewGeometry(
          da.ReadTwoViewGeometry(p.pair.image_id1, p.pair.image_id2));
    }
    for (const VerifiedPair& p : db.ReadVerifiedPairs(1)) {
      TwoViewGeometry g =
          db.ReadTwoViewGeometry(p.pair.image_id1, p.pair.image_id2);
      g.pair = ImagePair(g.pair.image_id1 + offset, g.pair.image_id2 + offset);
      w.WriteTwoViewGeometry(g);
    }
  }
  MapperPaths paths;
  paths.database_path = tmp / "merged.db";
  paths.image_path = tmp / "a/images";
  paths.output_path = tmp / "out";
  const nlohmann::json summary =
      RunHierarchicalMapper(paths, HierarchicalMapperOptions());
  EXPECT_EQ(summary["components"], 2);
  EXPECT_EQ(summary["isolated_images"], 1);
  EXPECT_EQ(summary["registered_images"], 28);
  ASSERT_TRUE(fs::exists(tmp / "out/0/images.bin"));
  ASSERT_TRUE(fs::exists(tmp / "out/1/images.bin"));
  const Reconstruction m0 = ReadModel(tmp / "out/0");
  const Reconstruction m1 = ReadModel(tmp / "out/1");
  EXPECT_EQ(m0.NumRegImages(), 16u);
  EXPECT_EQ(m1.NumRegImages(), 12u);
  const PoseEvaluation e0 =
      EvaluateModel(m0, ReadModel(tmp / "a/ground_truth"), {});
  EXPECT_TRUE(e0.correct) << e0.verdict_reason;
  // Model 1 names carry the prefix: compare by renaming the reference.
  Reconstruction ref_b = ReadModel(tmp / "b/ground_truth");
  for (auto& [id, im] : ref_b.images) im.name = "b_" + im.name;
  const PoseEvaluation e1 = EvaluateModel(m1, ref_b, {});
  EXPECT_TRUE(e1.correct) << e1.verdict_reason;
}

// A street crossing (held-out seed of the synthetic families) whose scaffold
// colmap splits where a weak true bridge joins the streets, and whose attach
// stage enters a stretch of street through a single image that has too few
// points for the next images there. Without merging the sub-models and
// re-seeding the stretch, 22 of its 150 images stayed unregistered.
TEST(HierarchicalMapper, MergesSubModelsAndReseedsWhatTheAttachLeaves) {
  if (!ColmapAvailable()) GTEST_SKIP() << "colmap is not installed";
  TempDir tmp;
  const MapperPaths paths =
      SynthScene(tmp, "crossing_streets", 150, 6, true);
  const nlohmann::json summary =
      RunHierarchicalMapper(paths, HierarchicalMapperOptions());
  ASSERT_EQ(summary["models"].size(), 1u);
  const nlohmann::json& stats = summary["models"][0];
  EXPECT_EQ(summary["registered_images"], 150)
      << "merged sub-models: " << stats["scaffold_merged_sub_models"]
      << ", re-seeded images: " << stats["reseeded_images"];
  const PoseEvaluation e = EvaluateModel(ReadModel(tmp / "out/0"),
                                         ReadModel(tmp / "scene/ground_truth"),
                                         {});
  EXPECT_TRUE(e.correct) << e.verdict_reason;
}

// The doppelganger pairs of a synthetic scene's pair_labels.txt, as sorted
// name pairs.
std::set<std::pair<std::string, std::string>> DoppelgangerPairs(
    const std::string& labels_path) {
  std::set<std::pair<std::string, std::string>> pairs;
  for (const PairLabel& l : ReadPairLabels(labels_path)) {
    if (l.IsDoppelganger()) pairs.insert(std::minmax(l.name1, l.name2));
  }
  return pairs;
}

// The bridges (entries of a view graph JSON's `list`) whose image names
// form a pair of `pairs`, as sorted name pairs; `outvoted_only` keeps those
// marked outvoted.
std::set<std::pair<std::string, std::string>> BridgesAmong(
    const nlohmann::json& view_graph, const std::string& list,
    const std::set<std::pair<std::string, std::string>>& pairs,
    bool outvoted_only = false) {
  std::map<int64_t, std::string> names;
  for (const nlohmann::json& im : view_graph.at("images")) {
    names[im.at("image_id").get<int64_t>()] = im.at("name").get<std::string>();
  }
  std::set<std::pair<std::string, std::string>> found;
  for (const nlohmann::json& b : view_graph.at(list)) {
    if (outvoted_only && !b.value("outvoted", false)) continue;
    const auto names12 = std::minmax(names[b.at("image_id1").get<int64_t>()],
                                     names[b.at("image_id2").get<int64_t>()]);
    if (pairs.count(names12)) found.insert(names12);
  }
  return found;
}

// Two streets crossing at 57 degrees (tuning seed 3 of the family): the
// first tree's first bridge between the streets is a doppelganger of rank 7
// scoring 0.67, whose cycles with the heavier true pairs at the crossing
// turn by about the angle between the streets. Without the peer vote
// (SkeletonOptions::peer_vote_size) the skeleton takes doppelganger bridges,
// and the model folds the streets (measured when the vote was added; the
// test checks the cause, on the hierarchy, so that the mapper runs once).
// With the vote each of them is outvoted and the model is correct.
TEST(HierarchicalMapper, PeerVoteRefusesADoppelgangerBetweenCrossingStreets) {
  if (!ColmapAvailable()) GTEST_SKIP() << "colmap is not installed";
  TempDir tmp;
  const MapperPaths paths = SynthScene(tmp, "crossing_streets", 40, 3, true);
  const auto doppelgangers = DoppelgangerPairs(tmp / "scene/pair_labels.txt");
  ASSERT_FALSE(doppelgangers.empty());

  HierarchicalMapperOptions off;
  off.hierarchy.skeleton.peer_vote_size = 0;
  const nlohmann::json off_graph =
      ComputeViewGraphJson(paths.database_path, paths.image_path, off);
  EXPECT_EQ(off_graph["num_outvoted_bridges"], 0);
  const auto taken_without_vote =
      BridgesAmong(off_graph, "skeleton_bridges", doppelgangers);
  ASSERT_FALSE(taken_without_vote.empty())
      << "the premise: without the vote the skeleton takes a doppelganger";

  // The sequence pass would remove those doppelgangers before the
  // hierarchy is built (the names are in capture order): off, so that the
  // vote is what is tested.
  HierarchicalMapperOptions on;
  on.sequence.sequence.mode = "off";
  on.hierarchy.skeleton.peer_vote_size = 8;
  const nlohmann::json summary = RunHierarchicalMapper(paths, on);
  EXPECT_GE(summary["outvoted_bridges"], 1);
  const nlohmann::json on_graph =
      nlohmann::json::parse(ReadTextFile(tmp / "out_work/view_graph.json"));
  const auto outvoted =
      BridgesAmong(on_graph, "rejected_bridges", doppelgangers, true);
  for (const auto& pair : taken_without_vote) {
    EXPECT_TRUE(outvoted.count(pair))
        << pair.first << "-" << pair.second << " was not outvoted";
  }
  EXPECT_TRUE(BridgesAmong(on_graph, "skeleton_bridges", doppelgangers).empty());
  EXPECT_EQ(summary["registered_images"], 40);
  const PoseEvaluation e = EvaluateModel(ReadModel(tmp / "out/0"),
                                         ReadModel(tmp / "scene/ground_truth"),
                                         {});
  EXPECT_TRUE(e.correct) << e.verdict_reason;
}

// A straight street of repeated facades (tuning seed 7 of the family) where
// 739 of the 780 pairs are doppelgangers and some photos see no unique
// clutter: without the sequence pass the hierarchy folds the street (35% of
// pairs within 5 degrees when measured). The names give the capture order,
// so the chain of consecutive pairs is reconstructed first and the pairs
// that disagree with it are removed; the model is then correct.
TEST(HierarchicalMapper, SequencePassUnfoldsARepeatedStreet) {
  if (!ColmapAvailable()) GTEST_SKIP() << "colmap is not installed";
  TempDir tmp;
  MapperPaths paths = SynthScene(tmp, "facade_street", 40, 7, true);
  const Reconstruction truth = ReadModel(tmp / "scene/ground_truth");

  HierarchicalMapperOptions off;
  off.sequence.sequence.mode = "off";
  paths.output_path = tmp / "off";
  const nlohmann::json off_summary = RunHierarchicalMapper(paths, off);
  EXPECT_TRUE(off_summary["sequence"].is_null());
  EXPECT_FALSE(EvaluateModel(ReadModel(tmp / "off/0"), truth, {}).correct)
      << "the premise: without the pass the street folds";

  paths.output_path = tmp / "out";
  const nlohmann::json summary =
      RunHierarchicalMapper(paths, HierarchicalMapperOptions());
  const nlohmann::json& pass = summary["sequence"];
  EXPECT_TRUE(pass["applies"]);
  EXPECT_TRUE(pass["ran"]);
  EXPECT_EQ(pass["registered"], 40);
  EXPECT_GT(pass["pairs_removed"].get<int>(), 600);
  EXPECT_FALSE(pass["chain_written"]) << "the hierarchy made the model";
  EXPECT_EQ(summary["registered_images"], 40);
  const PoseEvaluation e =
      EvaluateModel(ReadModel(tmp / "out/0"), truth, {});
  EXPECT_TRUE(e.correct) << e.verdict_reason;
}

// When no sub-model can be merged (a merge that needs more shared points
// than any model has) or joined, what the re-seeding registers is not
// dropped: it is written as further models, each image in one model only.
TEST(HierarchicalMapper, ReseededModelsAreJoinedOrWrittenApart) {
  if (!ColmapAvailable()) GTEST_SKIP() << "colmap is not installed";
  TempDir tmp;
  const MapperPaths paths =
      SynthScene(tmp, "crossing_streets", 150, 6, true);
  HierarchicalMapperOptions options;
  // With the sequence pass the hierarchy leaves nothing to re-seed here:
  // off, so that the re-seeding is what is tested.
  options.sequence.sequence.mode = "off";
  options.merge.min_inliers = 1000000;
  options.join_separate_models = false;
  const nlohmann::json summary = RunHierarchicalMapper(paths, options);
  ASSERT_GE(summary["models"].size(), 2u)
      << "the scene no longer leaves images to re-seed";
  std::set<ImageId> seen;
  size_t total = 0;
  for (size_t k = 0; k < summary["models"].size(); ++k) {
    const nlohmann::json& stats = summary["models"][k];
    ASSERT_EQ(stats["path"], std::to_string(k));
    const Reconstruction model = ReadModel(tmp / ("out/" + std::to_string(k)));
    EXPECT_EQ(stats["registered_images"], model.NumRegImages());
    EXPECT_GE(model.NumRegImages(), 3u);
    for (const auto& [id, image] : model.images) {
      EXPECT_TRUE(seen.insert(id).second) << "image " << id << " twice";
    }
    total += model.NumRegImages();
    if (k == 0) {
      EXPECT_FALSE(stats.contains("separate_from"));
    } else {
      EXPECT_EQ(stats["separate_from"], "0");
    }
    // Each model is right in itself (its own gauge).
    PoseEvaluationOptions partial;
    partial.require_all_registered = false;
    const PoseEvaluation e = EvaluateModel(
        model, ReadModel(tmp / "scene/ground_truth"), partial);
    EXPECT_TRUE(e.correct) << "model " << k << ": " << e.verdict_reason;
  }
  EXPECT_EQ(summary["registered_images"], total);

  // The same models, joined through the hierarchy's edges between them
  // (MergeThroughMatches) although they share no image: fewer models, a
  // larger first one, and it is right.
  MapperPaths joined_paths = paths;
  joined_paths.output_path = tmp / "joined";
  options.join_separate_models = true;
  const nlohmann::json joined = RunHierarchicalMapper(joined_paths, options);
  EXPECT_LT(joined["models"].size(), summary["models"].size());
  const nlohmann::json& first = joined["models"][0];
  EXPECT_GT(first["joined_images"].get<size_t>(), 0u);
  EXPECT_GT(first["registered_images"].get<size_t>(),
            summary["models"][0]["registered_images"].get<size_t>());
  // Joining moves images between models; it neither adds nor loses any,
  // and still writes each image in one model only.
  EXPECT_EQ(joined["registered_images"], summary["registered_images"]);
  std::set<ImageId> joined_seen;
  for (size_t k = 0; k < joined["models"].size(); ++k) {
    const Reconstruction model =
        ReadModel(tmp / ("joined/" + std::to_string(k)));
    for (const auto& [id, image] : model.images) {
      EXPECT_TRUE(joined_seen.insert(id).second) << "image " << id << " twice";
    }
  }
  PoseEvaluationOptions partial;
  partial.require_all_registered = false;
  const PoseEvaluation e = EvaluateModel(
      ReadModel(tmp / "joined/0"), ReadModel(tmp / "scene/ground_truth"),
      partial);
  EXPECT_TRUE(e.correct) << e.verdict_reason;
}

// Writes an oracle plug-in's scores: each verified pair's true share of
// inliers, from the pair_labels.txt of a synthetic scene.
void WriteOracleScores(const std::string& labels_path,
                       const std::string& scores_path) {
  const std::vector<PairLabel> labels = ReadPairLabels(labels_path);
  ASSERT_FALSE(labels.empty()) << labels_path;
  std::ofstream out(scores_path);
  for (const PairLabel& l : labels) {
    ASSERT_GT(l.num_inliers, 0u) << l.name1 << " " << l.name2;
    out << l.name1 << ' ' << l.name2 << ' '
        << static_cast<double>(l.num_true) / l.num_inliers << '\n';
  }
}

// A randomized instance of a synthetic family in `tmp`, with mapper options
// whose plug-in verifier is the oracle: each pair's true share of inliers.
struct OracleScene {
  OracleScene(const TempDir& tmp, const std::string& family, int num_images,
              int seed)
      : dir(tmp.path()),
        paths(SynthScene(tmp, family, num_images, seed, true)) {
    WriteOracleScores(tmp / "scene/pair_labels.txt", tmp / "oracle.txt");
    truth = ReadModel(tmp / "scene/ground_truth");
    options.verifier.verifier = "scores:" + (tmp / "oracle.txt");
    // The plug-in's part in the hierarchy is what these tests check; the
    // sequence pass would clean the pairs before the plug-in sees them.
    options.sequence.sequence.mode = "off";
  }
  /// Runs the mapper with `options` into DIR/name; returns its summary and
  /// sets *evaluation (unless null) to its model's against the truth.
  nlohmann::json Run(const std::string& name,
                     PoseEvaluation* evaluation = nullptr) {
    paths.output_path = (fs::path(dir) / name).string();
    nlohmann::json summary = RunHierarchicalMapper(paths, options);
    if (evaluation) {
      *evaluation =
          EvaluateModel(ReadModel(paths.output_path + "/0"), truth, {});
    }
    return summary;
  }
  std::string dir;
  MapperPaths paths;
  Reconstruction truth;
  HierarchicalMapperOptions options;
};

// A 40-image repeated street (tuning seed of the synthetic families) whose
// hierarchy trusts a doppelganger: with a perfect plug-in verifier that
// judges the bridges only, the model folds; judging the trusted edges too
// makes it correct.
TEST(HierarchicalMapper, PlugInVerifierJudgesTheTrustedEdges) {
  if (!ColmapAvailable()) GTEST_SKIP() << "colmap is not installed";
  TempDir tmp;
  OracleScene scene(tmp, "facade_street", 40, 7);
  scene.options.verifier.judge_trusted_edges = false;
  PoseEvaluation bridges_only;
  scene.Run("bridges_only", &bridges_only);
  EXPECT_FALSE(bridges_only.correct) << "the premise: a trusted doppelganger";

  scene.options.verifier.judge_trusted_edges = true;
  PoseEvaluation judged;
  const nlohmann::json summary = scene.Run("judged", &judged);
  EXPECT_GT(summary["verification"]["rejected_trusted_edges"].get<size_t>(), 0u);
  EXPECT_GT(summary["verification"]["trusted_edges_scored"].get<size_t>(), 0u);
  EXPECT_GE(summary["verification"]["pairs_scored"].get<size_t>(),
            summary["verification"]["trusted_edges_scored"].get<size_t>());
  EXPECT_EQ(summary["registered_images"], 40);
  EXPECT_TRUE(judged.correct) << judged.verdict_reason;
}

// A loop around a block, 150 images: the paper's hierarchy (trusted edges
// judged too) is one chain of views; the plug-in scores the support edges
// the builtin verifier adds to its own hierarchy, and they join the edges
// the component is reconstructed from.
TEST(HierarchicalMapper, PlugInVerifierScoresSupportEdges) {
  if (!ColmapAvailable()) GTEST_SKIP() << "colmap is not installed";
  TempDir tmp;
  OracleScene scene(tmp, "block_loop", 150, 5);
  scene.options.verifier.verified_hierarchy.support_edges = 0;
  const nlohmann::json paper = scene.Run("paper");
  EXPECT_EQ(paper["verification"]["support_edges"].get<size_t>(), 0u);

  scene.options.verifier.verified_hierarchy.support_edges = 3;
  PoseEvaluation with;
  const nlohmann::json supported = scene.Run("supported", &with);
  const nlohmann::json& v = supported["verification"];
  EXPECT_GT(v["support_edges"].get<size_t>(), 0u);
  EXPECT_GE(
      v["support_edges_judged"].get<size_t>(),
      v["support_edges"].get<size_t>() + v["reserve_edges"].get<size_t>());
  // Each pair is asked of the plug-in once: a support edge the trusted-edge
  // rounds already scored is not asked again.
  // On this scene some support edges were trusted edges already scored.
  EXPECT_GT(v["support_edges_scored"].get<size_t>(), 0u);
  EXPECT_LT(v["support_edges_scored"].get<size_t>(),
            v["support_edges_judged"].get<size_t>());
  EXPECT_EQ(v["pairs_scored"].get<size_t>(),
            paper["verification"]["pairs_scored"].get<size_t>() +
                v["support_edges_scored"].get<size_t>());
  // Plug-in inliers are cleaned by default, keeping most of them.
  const size_t before = v["inliers_before_cleaning"].get<size_t>();
  const size_t after = v["inliers_after_cleaning"].get<size_t>();
  EXPECT_GT(before, 0u);
  EXPECT_LT(after, before);
  EXPECT_GT(after, before / 2);
  EXPECT_EQ(supported["hierarchy_edges"].get<size_t>(),
            paper["hierarchy_edges"].get<size_t>() +
                v["support_edges"].get<size_t>());
  EXPECT_EQ(supported["registered_images"], 150);
  EXPECT_TRUE(with.correct) << with.verdict_reason;
}

TEST(ExhaustiveFilter, DropsRejectedPairsAndKeepsTheInput) {
  const std::string db = SharedDataPath("yan2017/cup", "database.db");
  if (db.empty()) GTEST_SKIP() << "shared data not found: " << SharedDataDir();
  TempDir tmp;
  const uint64_t before = FileFingerprint(db);
  const nlohmann::json out = FilterPairsExhaustively(
      db, "", tmp / "filtered.db", ExhaustiveFilterOptions());
  EXPECT_EQ(FileFingerprint(db), before);
  EXPECT_EQ(out["scored_pairs"], 2016);
  const size_t kept = out["kept_pairs"].get<size_t>();
  EXPECT_GT(kept, 0u);
  EXPECT_LT(kept, 2016u);
  Database filtered(tmp / "filtered.db");
  EXPECT_EQ(filtered.NumVerifiedPairs(), kept);
  EXPECT_EQ(filtered.ReadDescriptors(1).rows(),
            Database(db).ReadDescriptors(1).rows());
  EXPECT_THROW(FilterPairsExhaustively(db, "", tmp / "filtered.db",
                                       ExhaustiveFilterOptions()),
               Error);
}

}  // namespace
}  // namespace hisfm
