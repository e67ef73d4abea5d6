#include "hisfm/recon/hierarchical_mapper.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <optional>
#include <set>

#include "hisfm/graph/graph_segments.h"
#include "hisfm/io/colmap_version.h"
#include "hisfm/io/database.h"
#include "hisfm/io/database_validation.h"
#include "hisfm/io/model.h"
#include "hisfm/recon/chain_scaffold.h"
#include "hisfm/recon/feature_pipeline.h"
#include "hisfm/recon/hierarchy_json.h"
#include "hisfm/recon/input_check.h"
#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"
#include "hisfm/util/interrupt.h"
#include "hisfm/util/logging.h"
#include "hisfm/util/string_util.h"
#include "hisfm/util/timer.h"
#include "hisfm/verify/view_graph_reader.h"

namespace fs = std::filesystem;

namespace hisfm {

void HierarchicalMapperOptions::Check() const {
  HISFM_CHECK_OPTION(min_num_matches, min_num_matches >= 1, ">= 1");
  HISFM_CHECK_OPTION(min_model_size, min_model_size >= 2, ">= 2");
  sequence.Check();
  HISFM_CHECK_OPTION(reseed_rounds, reseed_rounds >= 0, ">= 0");
  HISFM_CHECK_OPTION(filter_top_pairs, filter_top_pairs >= 0, ">= 0");
  HISFM_CHECK_OPTION(
      scaffold_segment_images,
      scaffold_segment_images == 0 || scaffold_segment_images >= 3,
      "0 or >= 3");
  HISFM_CHECK_OPTION(scaffold_segment_overlap,
                     scaffold_segment_images == 0 ||
                         (scaffold_segment_overlap >= 1 &&
                          scaffold_segment_overlap < scaffold_segment_images),
                     "in [1, scaffold_segment_images)");
  HISFM_CHECK_OPTION(scaffold_ba_global_ratio,
                     scaffold_ba_global_ratio >= 1.0, ">= 1.0");
  HISFM_CHECK_OPTION(refined_attach_ba_global_max_num_iterations,
                     refined_attach_ba_global_max_num_iterations >= 0, ">= 0");
  HISFM_CHECK_OPTION(scaffold_ba_global_max_refinements,
                     scaffold_ba_global_max_refinements >= 1, ">= 1");
  HISFM_CHECK_OPTION(ba_global_function_tolerance,
                     ba_global_function_tolerance >= 0, ">= 0");
  HISFM_CHECK_OPTION(ba_local_max_refinements,
                     ba_local_max_refinements >= 1, ">= 1");
  hierarchy.Check();
  verifier.Check();
  colmap.Check();
  merge.Check();
  join.Check();
}

namespace {

// Runs the pair filter on the union of every image's `top_pairs` strongest
// pairs (0 = all pairs) and removes what it rejects from the full graph.
// Only strong pairs are ever trusted without verification (top-k community
// edges, leaf edges, intra-community skeleton edges), so they are the ones
// worth judging; weaker pairs can only enter the skeleton as verified
// bridges. This keeps the filter's cost linear in the number of images.
PairFilterResult FilterStrongestPairs(const Database& database,
                                      const ViewGraph& graph, int top_pairs,
                                      const PairFilterOptions& options) {
  if (top_pairs <= 0) return FilterAmbiguousPairs(database, graph, options);
  std::vector<bool> strong(graph.NumEdges(), false);
  std::vector<size_t> incident;
  for (size_t i = 0; i < graph.NumImages(); ++i) {
    incident = graph.IncidentEdges(i);
    const size_t k = std::min<size_t>(top_pairs, incident.size());
    std::partial_sort(incident.begin(), incident.begin() + k, incident.end(),
                      [&](size_t a, size_t b) {
                        return graph.Edges()[a].weight >
                               graph.Edges()[b].weight;
                      });
    for (size_t t = 0; t < k; ++t) strong[incident[t]] = true;
  }
  std::vector<ViewGraphEdge> strong_edges;
  for (size_t e = 0; e < graph.NumEdges(); ++e) {
    if (strong[e]) strong_edges.push_back(graph.Edges()[e]);
  }
  PairFilterResult result = FilterAmbiguousPairs(
      database, ViewGraph::FromEdges(graph.Images(), strong_edges), options);
  std::set<ImagePair> removed;
  for (const RemovedPair& r : result.removed) removed.insert(r.pair);
  std::vector<ViewGraphEdge> kept;
  for (const ViewGraphEdge& e : graph.Edges()) {
    if (!removed.count(e.pair)) kept.push_back(e);
  }
  result.graph = ViewGraph::FromEdges(graph.Images(), kept);
  return result;
}

struct LoadedInput {
  std::unique_ptr<Database> database;
  ViewGraph graph;
  std::unordered_map<ImageId, std::string> names;
  Hierarchy hierarchy;
  std::string verifier_name;
  double read_seconds = 0;
  double filter_seconds = 0;
  double graph_seconds = 0;
  /// Verified pairs in the database (before the pair filter).
  size_t num_verified_pairs = 0;
  nlohmann::json pair_filter;
  /// The sequence pass's summary (null when it was not asked for).
  nlohmann::json sequence;
  /// Wall time of the sequence pass.
  double sequence_seconds = 0;
  /// The builtin multi-view verifier's outcome (verified_hierarchy.h):
  /// cleaned inliers of the hierarchy's edges, and counts.
  std::unordered_map<ImagePair, std::vector<FeatureMatch>, ImagePairHash>
      inliers;
  // Counts of the trusted-edge rounds (and of the builtin verifier).
  nlohmann::json verification;
  // The trusted edges the verifier rejected (graph/trusted_edges.h).
  std::vector<RejectedTrustedEdge> rejected_trusted_edges;
  // Verified pairs kept back for images the hierarchy cannot register
  // (VerifiedHierarchy::reserve_edges).
  std::vector<ViewGraphEdge> reserve_edges;
  // Pairs the sequence pass checked against its chain (SequenceCheckedPairs;
  // empty when it did not run).
  std::vector<ImagePair> sequence_checked_pairs;
  // The sequence pass's chain models (null when it did not run), and the
  // loop closures it kept (SequencePassResult::num_loop_closures).
  const std::vector<Reconstruction>* chain_models = nullptr;
  size_t sequence_loop_closures = 0;
};

// With a plug-in verifier (VerifierOptions::IsPlugIn), what the builtin
// verifier gives its own hierarchy (verified_hierarchy.h): each image's
// strongest pairs inside its component that `scorer` scores at least
// support_threshold join the edges the component is reconstructed from
// (those scoring at least the bridges' threshold but less are kept in
// reserve); with clean_plugin_inliers, every edge used keeps only the
// inliers that agree with the geometry the builtin edge test accepts for it.
// The plug-in's verdicts stand: the builtin's score is not used. `scorer`
// remembers its scores in `scores` (MemoScorer): the pairs it grows by are
// the ones the plug-in was asked about here. The pairs of `pre_verified`
// (trust_sequence_checks) keep their inliers.
void AddPlugInGeometry(const Database& db, BridgeScorer& scorer,
                       const PairScores& scores,
                       const HierarchicalMapperOptions& options,
                       const std::set<ImagePair>& pre_verified,
                       LoadedInput* in) {
  const VerifiedHierarchyOptions& o = options.verifier.verified_hierarchy;
  const size_t known = NumAskedOfScorer(scores, pre_verified);
  const size_t num_judged = AddSupportEdges(
      in->graph, scorer, o.support_edges, o.support_threshold, &in->hierarchy,
      &in->reserve_edges, options.hierarchy.skeleton.verify_threshold);
  const size_t num_scored = NumAskedOfScorer(scores, pre_verified);
  const size_t num_asked = num_scored - known;
  size_t before = 0;
  size_t after = 0;
  if (options.verifier.clean_plugin_inliers) {
    MultiViewVerifier geometry(db, in->graph, options.verifier.multiview);
    std::vector<ImagePair> used = in->hierarchy.Edges();
    for (const ViewGraphEdge& e : in->reserve_edges) used.push_back(e.pair);
    CleanInliers(used, geometry, &in->inliers, &before, &after, &pre_verified);
  }
  in->verification["support_edges_judged"] = num_judged;
  in->verification["support_edges_scored"] = num_asked;
  in->verification["pairs_scored"] = num_scored;
  in->verification["support_edges"] = in->hierarchy.support_edges.size();
  in->verification["reserve_edges"] = in->reserve_edges.size();
  in->verification["inliers_before_cleaning"] = before;
  in->verification["inliers_after_cleaning"] = after;
  HISFM_LOG_INFO(
      "support edges: {} pairs judged ({} new to the verifier), {} taken, {} "
      "in reserve; {} of {} inliers kept on the edges used",
      num_judged, num_asked, in->hierarchy.support_edges.size(),
      in->reserve_edges.size(), after, before);
}

// The pairs of `graph` (the cleaned database's) whose two images one of the
// sequence pass's chain models registers: the pass's transfer test judged
// each of them, and those left in the cleaned database agree with the chain
// or are loop closures the pass kept by their conflict with the unique
// points. The trusted edges the hierarchy's verifier rejected (`rejected`)
// are left out: when it judged them (trust_sequence_checks off), either
// judge's rejection stands.
std::vector<ImagePair> SequenceCheckedPairs(
    const ViewGraph& graph, const std::vector<Reconstruction>& chain_models,
    const std::vector<RejectedTrustedEdge>& rejected) {
  std::set<ImagePair> refused;
  for (const RejectedTrustedEdge& r : rejected) refused.insert(r.pair);
  std::unordered_map<ImageId, size_t> model_of;
  for (size_t m = 0; m < chain_models.size(); ++m) {
    for (const auto& [id, image] : chain_models[m].images) model_of[id] = m;
  }
  std::vector<ImagePair> out;
  for (const ViewGraphEdge& e : graph.Edges()) {
    const auto a = model_of.find(e.pair.image_id1);
    const auto b = model_of.find(e.pair.image_id2);
    if (a != model_of.end() && b != model_of.end() && a->second == b->second &&
        !refused.count(e.pair)) {
      out.push_back(e.pair);
    }
  }
  return out;
}

LoadedInput LoadAndBuildHierarchy(
    const std::string& database_path, const std::string& image_path,
    const HierarchicalMapperOptions& options,
    const std::vector<Reconstruction>& chain_models = {},
    const std::vector<ImagePair>& loop_closures = {}) {
  LoadedInput in;
  Timer timer;
  in.database = std::make_unique<Database>(database_path);
  LogHeading("Reading database");
  const std::vector<DatabaseImage> images = in.database->ReadImages();
  for (const DatabaseImage& im : images) in.names[im.image_id] = im.name;
  ThrowUnless(!in.names.empty(),
              StrCat("database has no images: ", database_path));
  in.graph = ReadViewGraph(*in.database, options.min_num_matches);
  ThrowUnless(in.graph.NumEdges() > 0,
              StrCat("database has no verified image pairs with at least ",
                     options.min_num_matches, " inliers (run colmap's "
                     "matcher first): ", database_path));
  CheckImagesUsable(*in.database, images, in.graph);
  in.read_seconds = timer.ElapsedSeconds();
  HISFM_LOG_INFO("{} images, {} verified pairs ({:.2f} s)",
                 in.graph.NumImages(), in.graph.NumEdges(), in.read_seconds);
  in.num_verified_pairs = in.graph.NumEdges();
  if (options.verifier.UsesPairFilter()) {
    ThrowIfInterrupted();
    LogHeading("Removing pairs explained by repeated structure");
    PairFilterResult filtered = FilterStrongestPairs(
        *in.database, in.graph, options.filter_top_pairs,
        options.verifier.pair_filter);
    in.pair_filter = PairFilterSummaryJson(filtered, in.graph.NumEdges());
    HISFM_LOG_INFO(
        "removed {} of {} pairs ({} distinctive, {} three-view, {} coverage; "
        "{:.2f} s)",
        filtered.removed.size(), in.graph.NumEdges(),
        filtered.num_removed_distinctive, filtered.num_removed_three_view,
        filtered.num_removed_coverage, filtered.seconds);
    in.filter_seconds = filtered.seconds;
    in.graph = std::move(filtered.graph);
  }

  timer.Restart();
  ThrowIfInterrupted();
  LogHeading("Building the hierarchy");
  const Database& db = *in.database;
  // The pairs the sequence pass's transfer test kept (trust_sequence_checks;
  // none when it kept loop closures: its chain drifted past the test, whose
  // agreement is then no proof). The verification summary's "pairs_scored"
  // counts the pairs asked of the verifier, not these.
  std::set<ImagePair> pre_verified;
  if (options.trust_sequence_checks && loop_closures.empty()) {
    for (const ImagePair& p :
         SequenceCheckedPairs(in.graph, chain_models, {})) {
      pre_verified.insert(p);
    }
  }
  std::set<ImagePair> answered;
  size_t num_pre_verified = 0;
  if (options.verifier.IsMultiView()) {
    MultiViewVerifier verifier(db, in.graph, options.verifier.multiview);
    in.verifier_name = verifier.Name();
    VerifiedHierarchy verified = BuildVerifiedHierarchy(
        options.verifier.burstiness_weights ? verifier.RankingGraph()
                                            : in.graph,
        verifier, options.hierarchy, options.verifier.verified_hierarchy,
        &pre_verified);
    num_pre_verified = verified.num_pre_verified;
    in.hierarchy = std::move(verified.hierarchy);
    in.inliers = std::move(verified.inliers);
    in.reserve_edges = std::move(verified.reserve_edges);
    in.verification = {{"rounds", verified.rounds},
                    {"rejected_trusted_edges", verified.rejected.size()},
                    {"unresolved_trusted_edges", verified.num_unresolved},
                    {"pairs_evaluated", verifier.NumEvaluated()},
                    {"inliers_before_cleaning", verified.num_inliers_before},
                    {"inliers_after_cleaning", verified.num_inliers_after}};
    HISFM_LOG_INFO(
        "multi-view verification: {} pairs judged, {} trusted edges "
        "rejected in {} round(s), {} of {} inliers kept on the hierarchy's "
        "edges",
        verifier.NumEvaluated(), verified.rejected.size(), verified.rounds,
        verified.num_inliers_after, verified.num_inliers_before);
    in.rejected_trusted_edges = std::move(verified.rejected);
  } else {
    // A verifier that does not read the communities is created once and
    // lent to every build (a scores file is parsed once).
    std::unique_ptr<BridgeScorer> reused;
    const ScorerFactory make_verifier =
        [&](const Communities& communities) -> std::unique_ptr<BridgeScorer> {
      if (reused) return std::make_unique<BorrowedScorer>(reused.get());
      VerifierContext context;
      context.database = &db;
      context.graph = &in.graph;
      const bool per_build = options.verifier.UsesCommunities();
      context.communities = per_build ? &communities : nullptr;
      context.image_path = image_path;
      context.image_names = in.names;
      std::unique_ptr<BridgeScorer> scorer =
          CreateVerifier(options.verifier, context);
      in.verifier_name = scorer->Name();
      if (per_build) return scorer;
      reused = std::move(scorer);
      return std::make_unique<BorrowedScorer>(reused.get());
    };
    const ScorerFactory make_scorer =
        [&](const Communities& communities) -> std::unique_ptr<BridgeScorer> {
      std::unique_ptr<BridgeScorer> made = make_verifier(communities);
      if (!made || pre_verified.empty()) return made;
      return std::make_unique<PreVerifiedScorer>(std::move(made), &pre_verified,
                                                 &answered);
    };
    // Every score, so that the support edges ask the plug-in only about
    // pairs the hierarchy's rounds did not.
    PairScores scores;
    if (options.verifier.judge_trusted_edges) {
      JudgedHierarchy judged = BuildHierarchyJudgingTrustedEdges(
          in.graph, make_scorer, options.hierarchy,
          options.verifier.verified_hierarchy.trusted_edges);
      in.hierarchy = std::move(judged.hierarchy);
      const size_t num_scored = NumAskedOfScorer(judged.scores, pre_verified);
      in.verification = {{"rounds", judged.rounds},
                         {"rejected_trusted_edges", judged.rejected.size()},
                         {"unresolved_trusted_edges", judged.num_unresolved},
                         {"trusted_edges_scored", judged.num_scored},
                         {"pairs_scored", num_scored}};
      HISFM_LOG_INFO(
          "trusted edges: {} scored, {} rejected in {} round(s); {} pairs "
          "scored in all",
          judged.num_scored, judged.rejected.size(), judged.rounds, num_scored);
      scores = std::move(judged.scores);
      in.rejected_trusted_edges = std::move(judged.rejected);
    } else {
      in.hierarchy = BuildHierarchy(
          in.graph,
          [&](const Communities& c) -> std::unique_ptr<BridgeScorer> {
            std::unique_ptr<BridgeScorer> made = make_scorer(c);
            if (!made) return nullptr;
            return std::make_unique<MemoScorer>(std::move(made), &scores);
          },
          options.hierarchy);
      in.verification = {
          {"pairs_scored", NumAskedOfScorer(scores, pre_verified)}};
    }
    if (options.verifier.IsPlugIn()) {
      MemoScorer memo(make_scorer(in.hierarchy.communities), &scores);
      AddPlugInGeometry(db, memo, scores, options, pre_verified, &in);
    }
    num_pre_verified = answered.size();
  }
  if (!pre_verified.empty()) {
    in.verification["pairs_pre_verified"] = num_pre_verified;
    HISFM_LOG_INFO(
        "{} of the {} pairs the sequence pass checked and kept were asked "
        "about and taken as verified, without the verifier",
        num_pre_verified, pre_verified.size());
  }
  in.graph_seconds = timer.ElapsedSeconds();
  const Hierarchy& h = in.hierarchy;
  HISFM_LOG_INFO(
      "{} communities, {} candidate bridges, K = {}, {} bridges taken, {} "
      "rejected, {} refused by the near-miss or peer vote, {} verified by '{}' "
      "({} for the first tree)",
      h.communities.NumCommunities(), h.skeleton.num_candidate_bridges,
      h.skeleton.num_trees, h.skeleton.bridges.size(),
      h.skeleton.rejected.size(), h.skeleton.num_outvoted,
      h.skeleton.num_verified, in.verifier_name,
      h.skeleton.num_verified_first_tree);
  HISFM_LOG_INFO(
      "skeleton: {} images, {} edges; hierarchy: {} edges; {} component(s); "
      "{} isolated image(s) ({:.2f} s)",
      h.skeleton.images.size(), h.skeleton.Edges().size(), h.Edges().size(),
      h.components.size(), h.isolated_images.size(), in.graph_seconds);
  if (!h.isolated_images.empty()) {
    HISFM_LOG_WARN("{} image(s) have no verified pair and are not registered",
                   h.isolated_images.size());
  }
  return in;
}

// Appends `flag value` unless the user's mapper arguments already set flag.
void AddDefaultFlag(const std::vector<std::string>& user,
                    const std::string& flag, const std::string& value,
                    std::vector<std::string>* args) {
  for (const std::string& a : user) {
    if (a == flag) return;
  }
  args->push_back(flag);
  args->push_back(value);
}

// The bundle adjustment flags both colmap runs share (an explicit --Mapper
// flag of the user's wins).
void AddBundleAdjustmentFlags(const HierarchicalMapperOptions& options,
                              std::vector<std::string>* args) {
  AddDefaultFlag(options.mapper_args, "--Mapper.ba_global_function_tolerance",
                 FormatScientific(options.ba_global_function_tolerance), args);
  AddDefaultFlag(options.mapper_args, "--Mapper.ba_local_max_refinements",
                 std::to_string(options.ba_local_max_refinements), args);
}

// The global adjustments' relative function tolerance: the user's
// --Mapper.ba_global_function_tolerance if given, else the option's.
std::string GlobalFunctionTolerance(const HierarchicalMapperOptions& options) {
  const std::vector<std::string>& user = options.mapper_args;
  for (size_t i = 0; i + 1 < user.size(); ++i) {
    if (user[i] == "--Mapper.ba_global_function_tolerance") return user[i + 1];
  }
  return FormatScientific(options.ba_global_function_tolerance);
}

void WriteImageList(const std::vector<ImageId>& ids,
                    const std::unordered_map<ImageId, std::string>& names,
                    const std::string& path) {
  std::ofstream out(path);
  for (ImageId id : ids) out << names.at(id) << '\n';
  ThrowUnless(out.good(), StrCat("cannot write ", path));
}

// A model folder and its number of registered images (read once).
struct ModelFolder {
  // "" if there is no model.
  std::string path;
  size_t num_registered = 0;
  // Sub-models merged into it (MergedModel).
  size_t num_merged = 0;
  // True when every part of it was bundle-adjusted to convergence (scaffold
  // segments refined by RefineSegment).
  bool converged = false;

  bool empty() const { return path.empty(); }
};

// The model in `path`, read once for its size.
ModelFolder ReadModelFolder(const std::string& path) {
  return {path, ReadModelBinary(path).NumRegImages()};
}

// Reads the numbered sub-model folders under `path` into `models` and
// returns their paths; a folder colmap left unreadable (e.g. interrupted
// while writing it) is logged and skipped.
std::vector<std::string> ReadableModels(const std::string& path,
                                        std::vector<Reconstruction>* models) {
  std::vector<std::string> folders;
  for (const std::string& folder : NumberedModelFolders(path)) {
    try {
      models->push_back(ReadModelBinary(folder));
      folders.push_back(folder);
    } catch (const Error& e) {
      HISFM_LOG_WARN("skipping sub-model {}: {}", folder, e.what());
    }
  }
  return folders;
}

// Describes a merge step's shared evidence for the log.
std::string SharedEvidence(const ModelMergeStep& step) {
  if (step.rigs_refused) return "rigs of several sensors are not merged";
  return StrCat(step.num_common_images, " shared image(s), ", step.num_inliers,
                " of ", step.num_correspondences, " shared points agree");
}

// The model of the numbered sub-model folders under `paths` (empty if none):
// the largest, with the others that share registered images merged into it
// when `options.merge_sub_models` (model_merge.h; the merged model is
// written to `merged_path`). Sub-models left out are logged with their sizes
// and, when merging, appended to `unmerged` if it is given.
ModelFolder MergedModel(const std::vector<std::string>& paths,
                        const std::string& merged_path,
                        const HierarchicalMapperOptions& options,
                        std::vector<Reconstruction>* unmerged = nullptr) {
  std::vector<std::string> folders;
  std::vector<Reconstruction> models;
  for (const std::string& path : paths) {
    for (const std::string& folder : ReadableModels(path, &models)) {
      folders.push_back(folder);
    }
  }
  if (folders.empty()) return {};
  ModelMergeResult merged;
  if (options.merge_sub_models) {
    merged = MergeModels(models, options.merge);
  } else {
    merged.base = LargestModelIndex(models);
    for (size_t i = 0; i < models.size(); ++i) {
      if (i == merged.base) continue;
      ModelMergeStep step;
      step.model = i;
      step.num_images = models[i].NumRegImages();
      merged.steps.push_back(step);
    }
  }
  const std::string& base = folders[merged.base];
  for (const ModelMergeStep& step : merged.steps) {
    if (step.merged) {
      HISFM_LOG_INFO("merged sub-model {} ({} registered images) into {}: {}",
                     folders[step.model], step.num_images, base,
                     SharedEvidence(step));
    } else {
      HISFM_LOG_WARN(
          "{} sub-model {} ({} registered images; {}); keeping {} ({} "
          "images)",
          unmerged && options.merge_sub_models ? "leaving out" : "dropping",
          folders[step.model], step.num_images, SharedEvidence(step), base,
          models[merged.base].NumRegImages());
    }
  }
  if (unmerged && options.merge_sub_models) {
    for (Reconstruction& model : UnmergedModels(models, merged)) {
      unmerged->push_back(std::move(model));
    }
  }
  if (!options.merge_sub_models || merged.NumMerged() == 0) {
    return {base, models[merged.base].NumRegImages()};
  }
  std::error_code ec;
  fs::remove_all(merged_path, ec);
  AtomicDirectory dir(merged_path);
  WriteModelBinary(merged.model, dir.path());
  dir.Commit();
  return {merged_path, merged.model.NumRegImages(), merged.NumMerged()};
}

// MergedModel of the sub-models under `path`, merged into `path`/merged.
ModelFolder MergedModel(const std::string& path,
                        const HierarchicalMapperOptions& options,
                        std::vector<Reconstruction>* unmerged = nullptr) {
  return MergedModel(std::vector<std::string>{path}, path + "/merged", options,
                     unmerged);
}

// The options of a component's filtered databases: the multi-view
// verifier's cleaned inliers replace the database's, if there are any.
FilteredDatabaseOptions ComponentDatabaseOptions(const LoadedInput& in) {
  FilteredDatabaseOptions filtered;
  if (!in.inliers.empty()) filtered.replace_inliers = &in.inliers;
  return filtered;
}

nlohmann::json ModelStats(const Reconstruction& model) {
  return {{"registered_images", model.NumRegImages()},
          {"points3D", model.NumPoints3D()},
          {"observations", model.NumObservations()},
          {"mean_track_length", model.MeanTrackLength()},
          {"mean_reprojection_error", model.MeanReprojectionError()}};
}

nlohmann::json HierarchySummary(const LoadedInput& in) {
  const Hierarchy& h = in.hierarchy;
  return {{"images", in.graph.NumImages()},
          {"verified_pairs", in.num_verified_pairs},
          {"pairs_after_filter", in.graph.NumEdges()},
          {"pair_filter", in.pair_filter},
          {"verification", in.verification},
          {"communities", h.communities.NumCommunities()},
          {"candidate_bridges", h.skeleton.num_candidate_bridges},
          {"num_trees", h.skeleton.num_trees},
          {"skeleton_bridges", h.skeleton.bridges.size()},
          {"rejected_bridges", h.skeleton.rejected.size()},
          {"outvoted_bridges", h.skeleton.num_outvoted},
          {"skeleton_images", h.skeleton.images.size()},
          {"skeleton_edges", h.skeleton.Edges().size()},
          {"leaf_edges", h.leaf_edges.size()},
          {"hierarchy_edges", h.Edges().size()},
          {"verifier", in.verifier_name},
          {"verifier_calls", h.skeleton.num_verified},
          {"verifier_calls_first_tree", h.skeleton.num_verified_first_tree},
          {"verifier_batches", h.skeleton.num_scorer_calls},
          {"verified_fraction",
           in.num_verified_pairs
               ? static_cast<double>(h.skeleton.num_verified) /
                     in.num_verified_pairs
               : 0.0},
          {"components", h.components.size()},
          {"isolated_images", h.isolated_images.size()}};
}

// Seconds spent in each stage, over all components.
struct StageTimes {
  double filter_databases = 0;
  double scaffold = 0;
  double attach = 0;
  double bundle_adjustment = 0;
  double retriangulation = 0;
};

// Where one component's stages read and write.
struct ComponentRun {
  std::string dir;
  std::string database_path;
  std::string image_path;

  std::string Log() const { return dir + "/colmap.log"; }
};

// Writes the component's filtered databases (the skeleton's edges, and the
// whole hierarchy's; with the multi-view verifier's cleaned inliers) and its
// image lists.
void PrepareComponent(const ComponentRun& run, const HierarchyComponent& comp,
                      const LoadedInput& in, StageTimes* times) {
  Timer timer;
  std::error_code ec;
  fs::create_directories(run.dir + "/scaffold", ec);
  fs::create_directories(run.dir + "/attached", ec);
  const FilteredDatabaseOptions filtered = ComponentDatabaseOptions(in);
  WriteFilteredDatabase(run.database_path, run.dir + "/skeleton.db",
                        comp.skeleton_edges, filtered);
  WriteFilteredDatabase(run.database_path, run.dir + "/hierarchy.db",
                        comp.edges, filtered);
  WriteImageList(comp.skeleton_images, in.names,
                 run.dir + "/skeleton_images.txt");
  WriteImageList(comp.images, in.names, run.dir + "/images.txt");
  times->filter_databases += timer.ElapsedSeconds();
}

struct ScaffoldOutcome {
  // The largest scaffold model, empty when colmap could not start one.
  ModelFolder model;
  // True when there is no scaffold and the leaves' stage starts from scratch.
  bool fallback = false;
  // The colmap runs it was reconstructed in (scaffold_segment_images).
  size_t num_segments = 1;
  // The scaffold's sub-models that could not be merged into `model`.
  std::vector<Reconstruction> unmerged;
  // True when it is the sequence pass's chain model, refined
  // (scaffold_from_sequence_chain).
  bool from_chain = false;
};

// colmap mapper's arguments for a scaffold run on the skeleton's images
// listed in `image_list`, writing its sub-models under `output`.
std::vector<std::string> ScaffoldArgs(const ComponentRun& run,
                                      const HierarchicalMapperOptions& options,
                                      const std::string& image_list,
                                      const std::string& output) {
  std::vector<std::string> args = {
      "mapper",       "--database_path",   run.dir + "/skeleton.db",
      "--image_path", run.image_path,      "--output_path",
      output,         "--image_list_path", image_list};
  args.insert(args.end(), options.mapper_args.begin(),
              options.mapper_args.end());
  for (const char* flag :
       {"--Mapper.ba_global_images_ratio", "--Mapper.ba_global_points_ratio"})
    AddDefaultFlag(options.mapper_args, flag,
                   FormatScientific(options.scaffold_ba_global_ratio), &args);
  AddDefaultFlag(options.mapper_args, "--Mapper.ba_global_max_refinements",
                 std::to_string(options.scaffold_ba_global_max_refinements),
                 &args);
  // A partial scaffold is still an anchor for the attach stage: keep small
  // sub-models (colmap discards those under 10 images).
  AddDefaultFlag(options.mapper_args, "--Mapper.min_model_size",
                 std::to_string(options.min_model_size), &args);
  AddBundleAdjustmentFlags(options, &args);
  return args;
}

// The skeleton's edges and the sequence's checked pairs between images that
// one of `models` registers.
std::vector<ImagePair> SegmentRefinementPairs(
    const HierarchyComponent& comp, const LoadedInput& in,
    const std::vector<Reconstruction>& models) {
  const auto registered = [&](ImageId id) {
    return std::any_of(
        models.begin(), models.end(),
        [&](const Reconstruction& m) { return m.images.count(id) > 0; });
  };
  std::set<ImagePair> pairs;
  for (const std::vector<ImagePair>* source :
       {&comp.skeleton_edges, &in.sequence_checked_pairs}) {
    for (const ImagePair& p : *source) {
      if (registered(p.image_id1) && registered(p.image_id2)) pairs.insert(p);
    }
  }
  return {pairs.begin(), pairs.end()};
}

// refine_with_sequence_pairs: re-triangulates each numbered sub-model under
// `output` (one scaffold segment's run) from the skeleton's edges and the
// sequence's checked pairs between its images, poses fixed (colmap
// point_triangulator), and bundle-adjusts it (colmap's defaults but the
// global adjustments' function tolerance), into
// the same numbers under `refined`. Returns `refined`, or `output` when
// there is nothing to refine (the option is off, or the sequence pass
// checked no pair) or colmap fails (logged).
std::string RefineSegment(const ComponentRun& run,
                          const HierarchyComponent& comp, const LoadedInput& in,
                          const HierarchicalMapperOptions& options,
                          const std::string& output, const std::string& refined,
                          StageTimes* times) {
  if (!options.refine_with_sequence_pairs ||
      in.sequence_checked_pairs.empty()) {
    return output;
  }
  std::vector<Reconstruction> models;
  const std::vector<std::string> folders = ReadableModels(output, &models);
  if (folders.empty()) return output;
  Timer timer;
  std::error_code ec;
  fs::remove_all(refined, ec);
  const std::string database = refined + ".db";
  const std::vector<ImagePair> pairs = SegmentRefinementPairs(comp, in, models);
  // Seconds spent writing the database (-1 until it is written): the rest
  // is the refinement's, failed or not.
  double filtered = -1;
  try {
    WriteFilteredDatabase(run.database_path, database, pairs,
                          ComponentDatabaseOptions(in));
    filtered = timer.ElapsedSeconds();
    times->filter_databases += filtered;
    double triangulation = 0, adjustment = 0;
    for (const std::string& folder : folders) {
      const std::string name = fs::path(folder).filename().string();
      const std::string points = StrCat(refined, "/triangulated", name);
      const std::string adjusted = StrCat(refined, "/", name);
      for (const std::string& dir : {points, adjusted}) {
        fs::create_directories(dir, ec);
        ThrowUnless(!ec, StrCat("cannot create ", dir, ": ", ec.message()));
      }
      // The skeleton's points are kept and extended (colmap 3.8's default,
      // as measured; later releases clear them by default).
      std::vector<std::string> args = {"point_triangulator",
                                       "--database_path",
                                       database,
                                       "--image_path",
                                       run.image_path,
                                       "--input_path",
                                       folder,
                                       "--output_path",
                                       points,
                                       "--clear_points",
                                       "0"};
      args.insert(args.end(), options.mapper_args.begin(),
                  options.mapper_args.end());
      triangulation += RunColmap(options.colmap, args, run.Log());
      adjustment +=
          RunColmap(options.colmap,
                    {"bundle_adjuster", "--input_path", points, "--output_path",
                     adjusted, "--BundleAdjustment.function_tolerance",
                     GlobalFunctionTolerance(options)},
                    run.Log());
      fs::remove_all(points, ec);
    }
    fs::remove(database, ec);
    times->retriangulation += triangulation + adjustment;
    HISFM_LOG_INFO(
        "refined from {} pairs (the skeleton's and the sequence's checked): "
        "re-triangulated in {:.1f} s, bundle-adjusted in {:.1f} s",
        pairs.size(), triangulation, adjustment);
    return refined;
  } catch (const Interrupted&) {
    throw;
  } catch (const Error& e) {
    if (filtered < 0) {
      times->filter_databases += timer.ElapsedSeconds();
    } else {
      times->retriangulation += timer.ElapsedSeconds() - filtered;
    }
    HISFM_LOG_WARN("scaffold segment refinement: {}; keeping it unrefined",
                   e.what());
    return output;
  }
}

// scaffold_from_sequence_chain: the sequence pass's chain model that can be
// the component's scaffold (ChainModelForScaffold), or null when the option
// is off, refine_with_sequence_pairs is off, or nothing could refine it (no
// checked pair).
const Reconstruction* ChainHoldingSkeleton(
    const HierarchyComponent& comp, const LoadedInput& in,
    const HierarchicalMapperOptions& options) {
  if (!options.scaffold_from_sequence_chain || !in.chain_models ||
      !options.refine_with_sequence_pairs ||
      in.sequence_checked_pairs.empty()) {
    return nullptr;
  }
  if (in.sequence_loop_closures > 0) {
    HISFM_LOG_INFO(
        "the sequence pass kept {} loop closure(s): its chain drifts, so the "
        "scaffold is reconstructed, not taken from it",
        in.sequence_loop_closures);
  }
  return ChainModelForScaffold(comp.skeleton_images, *in.chain_models,
                               in.sequence_loop_closures);
}

// Writes ChainSegment(chain, images) to `output`/0, as a colmap run on the
// images would write its first sub-model.
void WriteChainSegment(const Reconstruction& chain,
                       const std::vector<ImageId>& images,
                       const std::string& output) {
  const Reconstruction model = ChainSegment(chain, images);
  std::error_code ec;
  fs::remove_all(output + "/0", ec);
  fs::create_directories(output + "/0", ec);
  ThrowUnless(!ec, StrCat("cannot create ", output, "/0: ", ec.message()));
  WriteModelBinary(model, output + "/0");
}

// Incremental SfM on the skeleton only (paper, Sec. III-D), or, after the
// sequence pass, its chain model in the skeleton's segments, refined
// (ChainHoldingSkeleton). A skeleton of
// more than options.scaffold_segment_images images (with merge_sub_models)
// is reconstructed in
// overlapping segments (graph/graph_segments.h), one colmap run each, whose
// models are merged through the images they share. A skeleton that colmap
// cannot initialise (no good initial pair, or every sub-model below its
// minimum size) is not an error: the attach stage then reconstructs the
// component from scratch on the hierarchy's edges.
ScaffoldOutcome ReconstructScaffold(const ComponentRun& run,
                                    const HierarchyComponent& comp,
                                    const LoadedInput& in,
                                    const HierarchicalMapperOptions& options,
                                    StageTimes* times) {
  const Reconstruction* chain = ChainHoldingSkeleton(comp, in, options);
  const std::vector<std::vector<ImageId>> segments =
      GraphSegments(comp.skeleton_images, comp.skeleton_edges,
                    options.merge_sub_models
                        ? static_cast<size_t>(options.scaffold_segment_images)
                        : 0,
                    static_cast<size_t>(options.scaffold_segment_overlap));
  LogHeading(StrCat("Scaffold: ",
                    chain ? "the sequence pass's chain model, refined, on "
                          : "colmap mapper on ",
                    comp.skeleton_images.size(), " skeletal images, ",
                    comp.skeleton_edges.size(), " edges",
                    segments.size() > 1 ? StrCat(", in ", segments.size(),
                                                 " overlapping segments")
                                        : std::string()));
  ScaffoldOutcome outcome;
  outcome.num_segments = segments.size();
  Timer timer;
  // The segments' refinements are timed as stages of their own.
  const double refined_before =
      times->filter_databases + times->retriangulation;
  std::vector<std::string> outputs;
  size_t num_refined = 0;
  for (size_t j = 0; j < segments.size(); ++j) {
    std::string image_list = run.dir + "/skeleton_images.txt";
    std::string output = run.dir + "/scaffold";
    std::string what = "Scaffold: registering images";
    if (segments.size() > 1) {
      image_list = StrCat(run.dir, "/skeleton_images_", j, ".txt");
      output = StrCat(run.dir, "/scaffold/segment", j);
      what = StrCat("Scaffold segment ", j + 1, "/", segments.size(),
                    ": registering images");
      WriteImageList(segments[j], in.names, image_list);
      std::error_code ec;
      fs::create_directories(output, ec);
    }
    try {
      if (chain) {
        WriteChainSegment(*chain, segments[j], output);
      } else {
        RunColmapWithProgress(
            options.colmap, ScaffoldArgs(run, options, image_list, output),
            run.Log(), what, segments[j].size(), ParseMapperProgress);
      }
      outputs.push_back(segments.size() > 1 || chain
                            ? RefineSegment(run, comp, in, options, output,
                                            output + "_refined", times)
                            : output);
      if (outputs.back() != output) ++num_refined;
    } catch (const Interrupted&) {
      throw;
    } catch (const Error& e) {
      // The other segments may still merge around it.
      HISFM_LOG_WARN("scaffold{}: {}",
                     segments.size() > 1
                         ? StrCat(" segment ", j + 1, "/", segments.size())
                         : std::string(),
                     e.what());
    }
  }
  try {
    outcome.model = MergedModel(outputs, run.dir + "/scaffold/merged", options,
                                &outcome.unmerged);
    outcome.model.converged =
        !outcome.model.empty() && num_refined == segments.size();
    outcome.from_chain = chain != nullptr && !outcome.model.empty();
  } catch (const Interrupted&) {
    throw;
  } catch (const Error& e) {
    HISFM_LOG_WARN("scaffold: {}", e.what());
  }
  times->scaffold +=
      timer.ElapsedSeconds() -
      (times->filter_databases + times->retriangulation - refined_before);
  if (outcome.model.empty()) {
    outcome.fallback = true;
    HISFM_LOG_WARN(
        "scaffold: no model of the {} skeletal images (colmap could not "
        "start one, or the chain's segments could not be written); "
        "reconstructing the component from its whole hierarchy instead",
        comp.skeleton_images.size());
    return outcome;
  }
  HISFM_LOG_INFO("scaffold: {}/{} skeletal images registered ({:.1f} s)",
                 outcome.model.num_registered, comp.skeleton_images.size(),
                 timer.ElapsedSeconds());
  return outcome;
}

// Registers the remaining images on the hierarchy's edges only (paper, Sec.
// III-D), starting from the scaffold, or from scratch without one (an empty
// `scaffold`). Returns the model folder.
// `stage` names the database (STAGE.db) and the output folder (STAGE/) in
// the component's folder, and is "attached" for the hierarchy's edges.
ModelFolder AttachLeaves(const ComponentRun& run,
                         const HierarchyComponent& comp,
                         const HierarchicalMapperOptions& options,
                         const ModelFolder& scaffold, StageTimes* times,
                         const std::string& stage = "attached",
                         size_t num_edges = 0) {
  const size_t scaffold_size = scaffold.num_registered;
  const std::string database =
      run.dir + (stage == "attached" ? "/hierarchy.db" : "/" + stage + ".db");
  LogHeading(StrCat("Attach: registering ", comp.images.size() - scaffold_size,
                    " images on ", num_edges ? num_edges : comp.edges.size(),
                    " edges"));
  std::vector<std::string> args = {"mapper", "--database_path", database,
                                   "--image_path", run.image_path};
  if (!scaffold.empty()) {
    args.insert(args.end(), {"--input_path", scaffold.path});
  }
  const std::string out_dir = run.dir + "/" + stage;
  std::error_code ec;
  fs::create_directories(out_dir, ec);
  args.insert(args.end(), {"--output_path", out_dir, "--image_list_path",
                           run.dir + "/images.txt"});
  args.insert(args.end(), options.mapper_args.begin(),
              options.mapper_args.end());
  AddBundleAdjustmentFlags(options, &args);
  // Keep the attached model whatever its size (colmap discards models under
  // 10 images, and then fails when it cannot start another).
  AddDefaultFlag(options.mapper_args, "--Mapper.min_model_size",
                 std::to_string(options.min_model_size), &args);
  if (scaffold.converged &&
      options.refined_attach_ba_global_max_num_iterations > 0) {
    AddDefaultFlag(
        options.mapper_args, "--Mapper.ba_global_max_num_iterations",
        std::to_string(options.refined_attach_ba_global_max_num_iterations),
        &args);
  }
  if (!options.attach_refine_focal_length && !scaffold.empty()) {
    AddDefaultFlag(options.mapper_args, "--Mapper.ba_refine_focal_length",
                   "0", &args);
  }
  if (options.attach_local_only && !scaffold.empty()) {
    // No periodic global bundle adjustment while attaching: local bundle
    // adjustment after each registration, one global one at the end.
    for (const char* flag :
         {"--Mapper.ba_global_images_ratio", "--Mapper.ba_global_points_ratio"})
      AddDefaultFlag(options.mapper_args, flag, "1000000", &args);
    for (const char* flag :
         {"--Mapper.ba_global_images_freq", "--Mapper.ba_global_points_freq"})
      AddDefaultFlag(options.mapper_args, flag, "1000000000", &args);
  }
  Timer timer;
  std::string failure;
  try {
    RunColmapWithProgress(options.colmap, args, run.Log(),
                          "Attach: registering images", comp.images.size(),
                          ParseMapperProgress);
  } catch (const Interrupted&) {
    throw;
  } catch (const Error& e) {
    // colmap ends with an error when it cannot start a further model; what
    // it registered before is kept if it wrote it.
    failure = e.what();
  }
  const double seconds = timer.ElapsedSeconds();
  times->attach += seconds;
  const ModelFolder attached = fs::exists(out_dir + "/images.bin")
                                  ? ReadModelFolder(out_dir)
                                  : MergedModel(out_dir, options);
  if (attached.empty() && !failure.empty()) throw Error(failure);
  ThrowUnless(!attached.empty(),
              StrCat("colmap wrote no model after attaching leaves; see ",
                     run.Log()));
  if (!failure.empty()) HISFM_LOG_WARN("attach: {}", failure);
  HISFM_LOG_INFO("attached: {}/{} images registered ({:.1f} s)",
                 attached.num_registered, comp.images.size(), seconds);
  return attached;
}

// The component's images that `model` does not register.
std::set<ImageId> UnregisteredImages(const HierarchyComponent& comp,
                                     const Reconstruction& model) {
  std::set<ImageId> missing;
  for (const ImageId id : comp.images) {
    if (!model.images.count(id)) missing.insert(id);
  }
  return missing;
}

// The component's hierarchy edges and the reserve edges inside it that touch
// an image of `missing`.
std::set<ImagePair> EdgesWithReserve(const HierarchyComponent& comp,
                                     const LoadedInput& in,
                                     const std::set<ImageId>& missing) {
  std::set<ImagePair> edges(comp.edges.begin(), comp.edges.end());
  const std::set<ImageId> members(comp.images.begin(), comp.images.end());
  for (const ViewGraphEdge& e : in.reserve_edges) {
    const ImageId a = e.pair.image_id1, b = e.pair.image_id2;
    if (members.count(a) && members.count(b) &&
        (missing.count(a) || missing.count(b))) {
      edges.insert(e.pair);
    }
  }
  return edges;
}

// Registers the images of the component that the hierarchy's edges left
// unregistered through their reserve edges (verified, but below the support
// threshold), starting from the attached model; returns the model with more
// registered images. A failing rescue is logged and the attached model kept,
// as a failing scaffold falls back to the attach stage.
ModelFolder RescueUnregistered(const ComponentRun& run,
                               const HierarchyComponent& comp,
                               const LoadedInput& in,
                               const HierarchicalMapperOptions& options,
                               const ModelFolder& attached,
                               StageTimes* times) {
  if (in.reserve_edges.empty()) return attached;
  const std::set<ImageId> missing =
      UnregisteredImages(comp, ReadModelBinary(attached.path));
  if (missing.empty()) return attached;
  const std::set<ImagePair> edges = EdgesWithReserve(comp, in, missing);
  const size_t num_reserve =
      edges.size() -
      std::set<ImagePair>(comp.edges.begin(), comp.edges.end()).size();
  if (num_reserve == 0) return attached;
  HISFM_LOG_INFO("rescue: {} unregistered image(s), {} reserve edge(s)",
                 missing.size(), num_reserve);
  Timer timer;
  WriteFilteredDatabase(run.database_path, run.dir + "/rescued.db",
                        {edges.begin(), edges.end()},
                        ComponentDatabaseOptions(in));
  times->filter_databases += timer.ElapsedSeconds();
  ModelFolder rescued;
  try {
    rescued = AttachLeaves(run, comp, options, attached, times, "rescued",
                           edges.size());
  } catch (const Interrupted&) {
    throw;
  } catch (const Error& e) {
    HISFM_LOG_WARN("rescue: {}; keeping the attached model", e.what());
    return attached;
  }
  return rescued.num_registered > attached.num_registered ? rescued
                                                          : attached;
}

// The optional extra global bundle adjustment; returns the final model.
std::string RefineModel(const ComponentRun& run, const ModelFolder& attached,
                        const HierarchicalMapperOptions& options,
                        StageTimes* times) {
  if (!options.global_bundle_adjustment) return attached.path;
  LogHeading("Global bundle adjustment");
  std::error_code ec;
  fs::create_directories(run.dir + "/refined", ec);
  const double seconds = RunColmap(
      options.colmap,
      {"bundle_adjuster", "--input_path", attached.path, "--output_path",
       run.dir + "/refined"},
      run.Log());
  times->bundle_adjustment += seconds;
  HISFM_LOG_INFO("bundle adjustment done ({:.1f} s)", seconds);
  return run.dir + "/refined";
}

// The hierarchy as JSON (HierarchyToJson) with the trusted edges the
// verifier rejected ("rejected_trusted_edges").
nlohmann::json ViewGraphJson(const LoadedInput& in) {
  nlohmann::json out = HierarchyToJson(in.hierarchy, in.graph, in.names);
  out["rejected_trusted_edges"] =
      RejectedTrustedEdgesToJson(in.rejected_trusted_edges);
  return out;
}

// Writes ViewGraphJson(in) to `path`.
void WriteViewGraphJson(const LoadedInput& in, const std::string& path) {
  std::ofstream out(path);
  out << ViewGraphJson(in).dump(1);
}

// Checks the mapper's paths before any work: a readable database, an image
// folder, a missing or empty output folder (normalized into
// `output_path`) and a work folder apart from the output and the inputs.
// Returns the work folder.
std::string CheckMapperPaths(const MapperPaths& paths,
                             std::string* output_path) {
  CheckFileReadable(paths.database_path, "database");
  CheckDirectoryExists(paths.image_path, "image folder");
  ThrowUnless(!paths.output_path.empty(), "--output_path is required");
  // "out/", "./out" and "out" name one folder: normalized before the work
  // folder's name is derived from it.
  *output_path = NormalizePath(paths.output_path);
  std::error_code ec;
  ThrowUnless(
      !fs::exists(*output_path, ec) || fs::is_directory(*output_path, ec),
      StrCat("output path is a file, not a folder: ", *output_path));
  ThrowUnless(IsMissingOrEmptyDirectory(*output_path),
              StrCat("output folder is not empty: ", *output_path));
  const std::string work = NormalizePath(
      paths.work_path.empty() ? *output_path + "_work" : paths.work_path);
  ThrowUnless(!IsSameOrInside(work, *output_path) &&
                  !IsSameOrInside(*output_path, work),
              StrCat("--work_path ", work, " and --output_path ",
                     *output_path, " must not contain each other"));
  for (const std::string& input : {paths.database_path, paths.image_path}) {
    ThrowUnless(!IsSameOrInside(input, work),
                StrCat("--work_path ", work, " holds the input ", input));
  }
  return work;
}

// One round of ReseedUnregistered (numbered `round`): the model it grew to,
// or nothing if it registered no more images than `current`; the new models
// that could not be merged into it are appended to `unmerged`.
std::optional<ModelFolder> ReseedRound(const ComponentRun& run,
                                       const HierarchyComponent& comp,
                                       const LoadedInput& in,
                                       const HierarchicalMapperOptions& options,
                                       const ModelFolder& current, int round,
                                       StageTimes* times,
                                       std::vector<Reconstruction>* unmerged) {
  const Reconstruction base = ReadModelBinary(current.path);
  const std::set<ImageId> missing = UnregisteredImages(comp, base);
  if (missing.empty()) return std::nullopt;
  const std::set<ImagePair> edges = EdgesWithReserve(comp, in, missing);
  std::set<ImageId> seeded = missing;
  for (const ImagePair& e : edges) {
    if (missing.count(e.image_id1) != missing.count(e.image_id2)) {
      seeded.insert(e.image_id1);
      seeded.insert(e.image_id2);
    }
  }
  const std::string stage = "reseed" + std::to_string(round);
  LogHeading(StrCat("Reseed: new models on ", missing.size(),
                    " unregistered image(s) and ",
                    seeded.size() - missing.size(),
                    " registered neighbour(s)"));
  Timer timer;
  const std::string database = run.dir + "/" + stage + ".db";
  const std::string image_list = run.dir + "/" + stage + "_images.txt";
  WriteFilteredDatabase(run.database_path, database,
                        {edges.begin(), edges.end()},
                        ComponentDatabaseOptions(in));
  WriteImageList({seeded.begin(), seeded.end()}, in.names, image_list);
  times->filter_databases += timer.ElapsedSeconds();
  const std::string models_dir = run.dir + "/" + stage + "_models";
  std::error_code ec;
  fs::create_directories(models_dir, ec);
  std::vector<std::string> args = {
      "mapper",       "--database_path", database,
      "--image_path", run.image_path,    "--output_path",
      models_dir,     "--image_list_path", image_list};
  args.insert(args.end(), options.mapper_args.begin(),
              options.mapper_args.end());
  AddBundleAdjustmentFlags(options, &args);
  AddDefaultFlag(options.mapper_args, "--Mapper.min_model_size",
                 std::to_string(options.min_model_size), &args);
  Timer seed_timer;
  try {
    RunColmapWithProgress(options.colmap, args, run.Log(),
                          "Reseed: registering images", seeded.size(),
                          ParseMapperProgress);
  } catch (const Interrupted&) {
    throw;
  } catch (const Error& e) {
    // colmap ends with an error when it cannot start a further model; the
    // models it wrote before are still used.
    HISFM_LOG_WARN("reseed: {}", e.what());
  }
  times->attach += seed_timer.ElapsedSeconds();
  std::vector<Reconstruction> models = {base};
  const size_t num_new = ReadableModels(models_dir, &models).size();
  // The component's model is the base: its frame and cameras are kept.
  const ModelMergeResult merged = MergeModels(models, options.merge, 0);
  HISFM_LOG_INFO("reseed: {} new model(s), {} merged; {} -> {} images",
                 num_new, merged.NumMerged(), base.NumRegImages(),
                 merged.model.NumRegImages());
  for (Reconstruction& model : UnmergedModels(models, merged)) {
    unmerged->push_back(std::move(model));
  }
  if (merged.model.NumRegImages() <= base.NumRegImages()) return std::nullopt;
  const std::string merged_dir = run.dir + "/" + stage + "_merged";
  AtomicDirectory dir(merged_dir);
  WriteModelBinary(merged.model, dir.path());
  dir.Commit();
  const ModelFolder joined = {merged_dir, merged.model.NumRegImages(),
                              merged.NumMerged()};
  ModelFolder attached;
  try {
    attached = AttachLeaves(run, comp, options, joined, times, stage,
                            edges.size());
  } catch (const Interrupted&) {
    throw;
  } catch (const Error& e) {
    HISFM_LOG_WARN("reseed: {}; keeping the merged model", e.what());
  }
  return attached.num_registered >= joined.num_registered ? attached : joined;
}

// Re-seeds the images of the component that are still unregistered:
// colmap mapper starts new models on them and their registered neighbours
// (on the hierarchy's and the reserve edges only), those that share
// registered images with the component's model are merged into it
// (model_merge.h), and one more attach run extends the merged model.
// Incremental SfM cannot always continue a model into a region it entered
// through one image: the next image there needs 3D points that only it and
// that image see, and nothing triangulated them. A model started inside the
// region has them. Repeats up to options.reseed_rounds times while it
// registers more images; returns the best model. The new models that could
// not be merged are appended to `unmerged` (several rounds may hold the same
// images; DisjointModels sorts that out).
ModelFolder ReseedUnregistered(const ComponentRun& run,
                               const HierarchyComponent& comp,
                               const LoadedInput& in,
                               const HierarchicalMapperOptions& options,
                               const ModelFolder& model, StageTimes* times,
                               std::vector<Reconstruction>* unmerged) {
  if (!options.merge_sub_models) return model;
  ModelFolder current = model;
  for (int round = 0; round < options.reseed_rounds; ++round) {
    try {
      const std::optional<ModelFolder> grown = ReseedRound(
          run, comp, in, options, current, round, times, unmerged);
      if (!grown) break;
      current = *grown;
    } catch (const Interrupted&) {
      throw;
    } catch (const Error& e) {
      HISFM_LOG_WARN("reseed: {}; keeping the model of {} images", e.what(),
                     current.num_registered);
      break;
    }
  }
  return current;
}

// The database's inlier matches of the edges of `edges` between an image of
// `a` and one of `b`. Not the verifier's cleaned
// inliers: the join's own robust fit keeps the matches that agree, and on
// crossing_streets_1000_s7 the cleaning left 8 of the 16 matched points of
// the two edges between its streets' models.
std::vector<PairMatches> MatchesBetween(const std::set<ImagePair>& edges,
                                        const LoadedInput& in,
                                        const Reconstruction& a,
                                        const Reconstruction& b) {
  std::vector<PairMatches> out;
  for (const ImagePair& e : edges) {
    const bool across =
        (a.images.count(e.image_id1) && b.images.count(e.image_id2)) ||
        (b.images.count(e.image_id1) && a.images.count(e.image_id2));
    if (!across) continue;
    try {
      out.push_back(
          {e, in.database->ReadInlierMatches(e.image_id1, e.image_id2)});
    } catch (const Error& err) {
      HISFM_LOG_WARN("join: skipping the edge {}-{}: {}", e.image_id1,
                     e.image_id2, err.what());
    }
  }
  return out;
}

// Joins the models of `separate` (of the scaffold or the re-seeding, none
// sharing an image with the component's model `model`, read from
// `attached`, nor with each other) that the component's hierarchy and
// reserve edges tie to it through matched 3D points (MergeThroughMatches),
// repeating while any joins. Returns the joined model's folder (`attached`
// if none joined); `separate` keeps the others.
ModelFolder JoinSeparateModels(const ComponentRun& run,
                               const HierarchyComponent& comp,
                               const LoadedInput& in,
                               const HierarchicalMapperOptions& options,
                               const ModelFolder& attached,
                               Reconstruction model,
                               std::vector<Reconstruction>* separate) {
  // The last attempt on each model; `separate` changes only once the joined
  // model is written.
  std::vector<ModelMergeStep> steps(separate->size());
  const std::set<ImagePair> edges = EdgesWithReserve(
      comp, in, std::set<ImageId>(comp.images.begin(), comp.images.end()));
  size_t num_joined = 0;
  for (bool progress = true; progress;) {
    progress = false;
    for (size_t i = 0; i < separate->size(); ++i) {
      if (steps[i].merged) continue;
      steps[i] = MergeThroughMatches((*separate)[i],
                                     MatchesBetween(edges, in, model,
                                                    (*separate)[i]),
                                     options.join, &model);
      if (steps[i].merged) {
        progress = true;
        ++num_joined;
      }
    }
  }
  for (const ModelMergeStep& step : steps) {
    HISFM_LOG_INFO(
        "{} a separate model of {} images through {} edge(s): {} of {} "
        "matched points agree",
        step.merged ? "joined" : "could not join", step.num_images,
        step.num_pairs, step.num_inliers, step.num_correspondences);
  }
  if (num_joined == 0) return attached;
  const std::string joined_dir = run.dir + "/joined";
  AtomicDirectory dir(joined_dir);
  WriteModelBinary(model, dir.path());
  dir.Commit();
  std::vector<Reconstruction> left;
  for (size_t i = 0; i < separate->size(); ++i) {
    if (!steps[i].merged) left.push_back(std::move((*separate)[i]));
  }
  *separate = std::move(left);
  return {joined_dir, model.NumRegImages(), attached.num_merged + num_joined};
}

// One component's final model and its scaffold.
struct ComponentModel {
  Reconstruction model;
  ScaffoldOutcome scaffold;
  // Images the re-seeding registered (ReseedUnregistered).
  size_t num_reseeded = 0;
  // Images of separate models joined to the model (JoinSeparateModels).
  size_t num_joined = 0;
  // Models of the scaffold or the re-seeding that could not be joined to
  // `model`, without its images: written as further models, as colmap
  // does.
  std::vector<Reconstruction> separate;
};

// Reconstructs one component: filtered databases, scaffold, attached leaves,
// rescued and re-seeded images, optional global bundle adjustment.
ComponentModel ReconstructComponent(const ComponentRun& run,
                                    const HierarchyComponent& comp,
                                    const LoadedInput& in,
                                    const HierarchicalMapperOptions& options,
                                    StageTimes* times) {
  PrepareComponent(run, comp, in, times);
  ComponentModel out;
  out.scaffold = ReconstructScaffold(run, comp, in, options, times);
  // The scaffold's sub-models left out hold images the later stages may
  // not reach: they are kept with the re-seeded models, joined or written
  // apart (JoinSeparateModels).
  out.separate = std::move(out.scaffold.unmerged);
  const ModelFolder rescued = RescueUnregistered(
      run, comp, in, options,
      AttachLeaves(run, comp, options, out.scaffold.model, times), times);
  const ModelFolder attached = ReseedUnregistered(run, comp, in, options,
                                                  rescued, times,
                                                  &out.separate);
  out.num_reseeded = attached.num_registered - rescued.num_registered;
  // Earlier rounds' models overlap later ones, and the attach runs may
  // have registered some of their images.
  Reconstruction model = ReadModelBinary(attached.path);
  out.separate = DisjointModels(model, std::move(out.separate),
                                static_cast<size_t>(options.min_model_size));
  ModelFolder joined = attached;
  try {
    if (options.join_separate_models && !out.separate.empty()) {
      joined = JoinSeparateModels(run, comp, in, options, attached,
                                  std::move(model), &out.separate);
    }
  } catch (const Interrupted&) {
    throw;
  } catch (const Error& e) {
    HISFM_LOG_WARN("join: {}; keeping the models apart", e.what());
  }
  out.num_joined = joined.num_registered - attached.num_registered;
  out.model = ReadModelBinary(RefineModel(run, joined, options, times));
  if (!out.separate.empty()) {
    size_t n = 0;
    for (const Reconstruction& m : out.separate) n += m.NumRegImages();
    HISFM_LOG_WARN(
        "{} image(s) in {} model(s) of the scaffold or the re-seeding could "
        "not be joined to the component's model: written as further models",
        n, out.separate.size());
  }
  return out;
}

// A component's entry in the summary's "models" (its model is `index`).
nlohmann::json ComponentStats(const ComponentModel& result,
                              const HierarchyComponent& comp, size_t index) {
  nlohmann::json stats = ModelStats(result.model);
  stats["component_images"] = comp.images.size();
  stats["scaffold_images"] = comp.skeleton_images.size();
  stats["scaffold_registered"] = result.scaffold.model.num_registered;
  stats["scaffold_fallback"] = result.scaffold.fallback;
  stats["scaffold_segments"] = result.scaffold.num_segments;
  stats["scaffold_merged_sub_models"] = result.scaffold.model.num_merged;
  stats["scaffold_from_chain"] = result.scaffold.from_chain;
  stats["reseeded_images"] = result.num_reseeded;
  stats["joined_images"] = result.num_joined;
  stats["path"] = std::to_string(index);
  return stats;
}

// The summary's entry for a model of the scaffold or the re-seeding of a
// component that could not be joined to the component's model
// (`main_index`); it is model `index`.
nlohmann::json SeparateModelStats(const Reconstruction& model, size_t index,
                                  size_t main_index) {
  nlohmann::json stats = ModelStats(model);
  stats["component_images"] = model.NumRegImages();
  stats["scaffold_images"] = 0;
  stats["scaffold_registered"] = 0;
  stats["separate_from"] = std::to_string(main_index);
  stats["path"] = std::to_string(index);
  return stats;
}

// The run's summary (hisfm_summary.json): the hierarchy's counts, the
// inputs, each model's statistics and the failed components, timings.
nlohmann::json MapperSummary(const LoadedInput& in, const MapperPaths& paths,
                             const std::string& work,
                             const HierarchicalMapperOptions& options,
                             size_t num_registered,
                             const nlohmann::json& models,
                             const nlohmann::json& failed,
                             const StageTimes& times, double total_seconds) {
  nlohmann::json summary = HierarchySummary(in);
  summary["database_path"] = fs::absolute(paths.database_path).string();
  summary["image_path"] = fs::absolute(paths.image_path).string();
  summary["work_path"] = fs::absolute(work).string();
  summary["colmap_version"] =
      ProbeColmap(options.colmap.colmap_path).version.text;
  summary["registered_images"] = num_registered;
  summary["models"] = models;
  summary["failed_components"] = failed;
  if (!models.empty()) {
    summary["points3D"] = models[0]["points3D"];
    summary["mean_reprojection_error"] = models[0]["mean_reprojection_error"];
    summary["mean_track_length"] = models[0]["mean_track_length"];
  }
  summary["sequence"] = in.sequence;
  summary["timings"] = {{"read_database", in.read_seconds},
                        {"sequence_pass", in.sequence_seconds},
                        {"filter_pairs", in.filter_seconds},
                        {"build_hierarchy", in.graph_seconds},
                        {"filter_databases", times.filter_databases},
                        {"scaffold", times.scaffold},
                        {"attach", times.attach},
                        {"retriangulation", times.retriangulation},
                        {"global_bundle_adjustment", times.bundle_adjustment},
                        {"total", total_seconds}};
  return summary;
}

}  // namespace

nlohmann::json ComputeViewGraphJson(const std::string& database_path,
                                    const std::string& image_path,
                                    const HierarchicalMapperOptions& options) {
  options.Check();
  RequireValidDatabase(database_path);
  LoadedInput in = LoadAndBuildHierarchy(database_path, image_path, options);
  nlohmann::json out = ViewGraphJson(in);
  out["summary"] = HierarchySummary(in);
  out["timings"] = {{"read_database", in.read_seconds},
                    {"filter_pairs", in.filter_seconds},
                    {"build_hierarchy", in.graph_seconds}};
  return out;
}

nlohmann::json RunHierarchicalMapper(const MapperPaths& paths,
                                     const HierarchicalMapperOptions& options) {
  options.Check();
  Timer total;
  std::string output_path;
  const std::string work = CheckMapperPaths(paths, &output_path);
  std::error_code ec;
  // Bad input stops here, in one line, before any colmap call.
  RequireValidDatabase(paths.database_path);
  // Also refuses a colmap release whose option names hisfm does not know.
  CheckColmapAvailable(options.colmap);
  // Work folders of earlier versions hold view_graph.json, written first.
  PrepareWorkDirectory(work, "view_graph.json");

  AtomicDirectory output(output_path);
  // The sequence pass's chain: this mapper without the pass, its work kept
  // under work/sequence, in folders named after each segment's database
  // (chain_3.db: chain_3_model, chain_3_work), as segments run side by side.
  const std::string sequence_work = work + "/sequence";
  const ChainReconstructor reconstruct_chain =
      [&](const std::string& chain_db) {
        HierarchicalMapperOptions chain_options = options;
        chain_options.sequence.sequence.mode = "off";
        chain_options.attach_refine_focal_length = false;
        const std::string stem =
            (fs::path(sequence_work) / fs::path(chain_db).stem()).string();
        MapperPaths chain_paths;
        chain_paths.database_path = chain_db;
        chain_paths.image_path = paths.image_path;
        chain_paths.output_path = stem + "_model";
        chain_paths.work_path = stem + "_work";
        std::error_code remove_ec;
        fs::remove_all(chain_paths.output_path, remove_ec);
        fs::remove_all(chain_paths.work_path, remove_ec);
        RunHierarchicalMapper(chain_paths, chain_options);
        return ReadNumberedModels(chain_paths.output_path);
      };
  // The rest reads the cleaned database when the pass ran.
  SequencePassResult pass;
  nlohmann::json sequence;
  if (options.sequence.sequence.mode != "off") {
    LogHeading("Checking the pairs against the capture sequence");
    pass =
        RunSequencePass(paths.database_path, options.min_num_matches,
                        sequence_work, reconstruct_chain, options.sequence);
    sequence = pass.ToJson();
    if (pass.ran) sequence["chain_written"] = false;
  }
  const std::string database_path =
      pass.ran ? pass.cleaned_database_path : paths.database_path;
  ThrowIfInterrupted();
  LoadedInput in =
      LoadAndBuildHierarchy(database_path, paths.image_path, options,
                            pass.chain_models, pass.loop_closures);
  in.sequence_seconds = pass.seconds;
  // The summary counts the input's pairs, not the cleaned copy's.
  if (pass.ran) {
    in.num_verified_pairs = pass.num_input_pairs;
    in.sequence_checked_pairs = SequenceCheckedPairs(
        in.graph, pass.chain_models, in.rejected_trusted_edges);
    in.chain_models = &pass.chain_models;
    in.sequence_loop_closures = pass.num_loop_closures;
  }
  const Hierarchy& h = in.hierarchy;

  WriteViewGraphJson(in, work + "/view_graph.json");

  nlohmann::json models = nlohmann::json::array();
  nlohmann::json failed = nlohmann::json::array();
  StageTimes times;
  size_t model_index = 0;
  size_t num_registered = 0;
  size_t largest_registered = 0;
  // Models of a component's scaffold or re-seeding that could not be joined
  // to it, with their component's model.
  std::vector<std::pair<Reconstruction, size_t>> separate;
  for (size_t c = 0; c < h.components.size(); ++c) {
    const HierarchyComponent& comp = h.components[c];
    if (comp.images.size() < static_cast<size_t>(options.min_model_size)) {
      HISFM_LOG_WARN("component {} has {} images: skipped", c,
                     comp.images.size());
      continue;
    }
    ThrowIfInterrupted();
    LogHeading(StrCat("Component ", c, ": ", comp.images.size(), " images, ",
                      comp.skeleton_images.size(), " in the scaffold"));
    const ComponentRun run{StrCat(work, "/component", c), database_path,
                           paths.image_path};
    try {
      ComponentModel result =
          ReconstructComponent(run, comp, in, options, &times);
      const std::string model_dir = StrCat(output.path(), "/", model_index++);
      fs::create_directories(model_dir, ec);
      WriteModelBinary(result.model, model_dir);
      num_registered += result.model.NumRegImages();
      largest_registered =
          std::max(largest_registered, result.model.NumRegImages());
      models.push_back(ComponentStats(result, comp, model_index - 1));
      for (Reconstruction& model : result.separate) {
        separate.push_back({std::move(model), model_index - 1});
      }
    } catch (const Interrupted&) {
      throw;
    } catch (const Error& e) {
      // One failing component does not discard the others.
      HISFM_LOG_WARN("component {} failed: {}", c, e.what());
      failed.push_back({{"component", c},
                        {"images", comp.images.size()},
                        {"error", e.what()}});
    }
  }
  // The scaffold's and re-seeding's models no component could join follow
  // every component's model, so that out/0, out/1, ... stay the components in their order.
  for (const auto& [model, main_index] : separate) {
    const std::string model_dir = StrCat(output.path(), "/", model_index++);
    fs::create_directories(model_dir, ec);
    WriteModelBinary(model, model_dir);
    num_registered += model.NumRegImages();
    models.push_back(SeparateModelStats(model, model_index - 1, main_index));
  }
  // Failing soft: where the hierarchy on the cleaned pairs registers fewer
  // images in one model than the chain did (the chain's models were joined
  // through every verified pair between them, the hierarchy's only through
  // its own edges), the chain's models are the result.
  size_t chain_registered = 0;
  for (const Reconstruction& model : pass.chain_models) {
    chain_registered += model.NumRegImages();
  }
  if (!pass.chain_models.empty() &&
      pass.chain_models[0].NumRegImages() > largest_registered &&
      chain_registered >= num_registered) {
    HISFM_LOG_WARN(
        "the hierarchy's largest model registers {} images, the capture "
        "sequence's chain {}: writing the chain's models instead",
        largest_registered, pass.chain_models[0].NumRegImages());
    for (size_t i = 0; i < model_index; ++i) {
      const std::string dir = StrCat(output.path(), "/", i);
      fs::remove_all(dir, ec);
      ThrowUnless(!ec, StrCat("cannot remove ", dir, ": ", ec.message()));
    }
    models = nlohmann::json::array();
    separate.clear();
    num_registered = 0;
    model_index = 0;
    for (const Reconstruction& model : pass.chain_models) {
      const std::string model_dir = StrCat(output.path(), "/", model_index);
      fs::create_directories(model_dir, ec);
      WriteModelBinary(model, model_dir);
      num_registered += model.NumRegImages();
      nlohmann::json stats = ModelStats(model);
      stats["component_images"] = model.NumRegImages();
      stats["scaffold_images"] = 0;
      stats["scaffold_registered"] = 0;
      stats["path"] = std::to_string(model_index++);
      stats["sequence_chain"] = true;
      models.push_back(stats);
    }
    sequence["chain_written"] = true;
  }
  in.sequence = sequence;
  ThrowUnless(model_index > 0,
              StrCat("no model could be reconstructed; see the logs in ",
                     work, failed.empty() ? std::string()
                                          : StrCat(" (first failure: ",
                                                   failed[0]["error"]
                                                       .get<std::string>(),
                                                   ")")));

  const nlohmann::json summary =
      MapperSummary(in, paths, work, options, num_registered, models, failed,
                    times, total.ElapsedSeconds());
  if (!paths.options_record.empty()) {
    WriteFileAtomically(output.path() + "/hisfm_options.ini",
                        paths.options_record);
  }
  WriteFileAtomically(output.path() + "/hisfm_summary.json",
                      summary.dump(2) + "\n");
  output.Commit();
  LogHeading(StrCat("Done: ", num_registered, " of ", in.graph.NumImages(),
                    " images registered in ", model_index, " model(s), ",
                    std::lround(total.ElapsedSeconds()), " s"));
  return summary;
}

}  // namespace hisfm
