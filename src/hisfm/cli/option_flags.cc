#include "hisfm/cli/option_flags.h"

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <cstring>
#include <map>
#include <set>
#include <sstream>

#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"
#include "hisfm/util/logging.h"

namespace hisfm {

namespace {

// The explicit table of the mapper's flags: calls visit(flag, option, help)
// for each flag and the option (field of `o`) it sets. It both adds the
// flags and names the flag of an option that fails its check.
template <typename Visit>
void ForEachMapperFlag(HierarchicalMapperOptions* o, Visit&& visit) {
  auto& h = o->hierarchy;
  visit("--HiSfM.min_num_matches", o->min_num_matches,
        "Ignore verified pairs with fewer inliers");
  auto& seq = o->sequence;
  visit("--HiSfM.sequence_prior", seq.sequence.mode,
        "Use the image names' order as the capture order: auto (when the "
        "matches show it), on or off");
  visit("--HiSfM.sequence_min_z_score", seq.sequence.min_z_score,
        "auto: consecutive names' inliers against shuffled orders, in "
        "standard deviations");
  visit("--HiSfM.sequence_min_consecutive_share",
        seq.sequence.min_consecutive_share,
        "auto: share of consecutive names that must be verified pairs");
  visit("--HiSfM.sequence_break_ratio", seq.sequence.break_ratio,
        "A consecutive pair weaker than this share of its neighbours' median "
        "breaks the chain");
  visit("--HiSfM.sequence_max_transfer_error",
        seq.agreement.max_transfer_error,
        "A match agrees with the chain when its 3D point projects this close "
        "(share of the image diagonal)");
  visit("--HiSfM.sequence_min_agreeing_share",
        seq.agreement.min_agreeing_share,
        "A pair is removed when fewer of its matches agree with the chain");
  visit("--HiSfM.sequence_chain_segment_images", seq.chain_segment_images,
        "Reconstruct the chain in overlapping segments of at most this many "
        "images, merged through their shared images (0 = one run)");
  visit("--HiSfM.sequence_chain_segment_overlap", seq.chain_segment_overlap,
        "Images consecutive chain segments share");
  visit("--HiSfM.sequence_chain_segment_parallel_runs",
        seq.chain_segment_parallel_runs,
        "Chain segments reconstructed side by side (1 = one after another)");
  visit("--HiSfM.sequence_require_one_model", seq.require_one_model,
        "Clean the pairs only when the chain's pieces join into one model");
  visit("--HiSfM.sequence_near_join_window", seq.near_join_window,
        "Join the chain's pieces first through the pairs at most this many "
        "places apart in an unbroken stretch of the chain (0 = off)");
  visit("--HiSfM.sequence_join_by_conflict", seq.join_by_conflict,
        "Join the chain's pieces that their pairs cannot join by the "
        "proposed join that conflicts least with their unique points");
  visit("--HiSfM.sequence_close_loops_by_conflict",
        seq.close_loops_by_conflict,
        "Keep the pairs across the halves of the chain's order that the "
        "chain rejects when they form the join of least conflict with the "
        "unique points (loop closures)");
  visit("--HiSfM.sequence_min_unique_found_share",
        seq.conflict_join.min_found_share,
        "A join by conflict (or loop closure) needs its pairs to match this "
        "share of the unique points it predicts");
  visit("--HiSfM.sequence_min_unique_share_ratio",
        seq.conflict_join.min_share_ratio,
        "... and this many times the share of the next best join");
  visit("--HiSfM.top_k", h.communities.top_k,
        "Strongest neighbours kept per image to form communities (k)");
  visit("--HiSfM.num_trees", h.skeleton.num_trees,
        "Spanning trees packed over the communities (K); 0 = "
        "max(1, round(n / images_per_tree))");
  visit("--HiSfM.images_per_tree", h.skeleton.images_per_tree,
        "Images per tree for the automatic K");
  visit("--HiSfM.verify_threshold", h.skeleton.verify_threshold,
        "Minimum verifier score for a bridge (tau)");
  visit("--HiSfM.redundant_threshold", h.skeleton.redundant_threshold,
        "Minimum score of a redundant bridge: trees after the first, "
        "backup, top-weight and connectivity bridges (at least tau)");
  visit("--HiSfM.redundant_budget_trees", h.skeleton.redundant_budget_trees,
        "After the first tree, verify at most this many times "
        "max(1, K - 1) trees' worth of redundant bridges");
  visit("--HiSfM.first_tree_budget_trees",
        h.skeleton.first_tree_budget_trees,
        "The first tree verifies at most this many trees' worth of bridges "
        "at tau, then goes on at the fallback threshold; 0 = no budget");
  visit("--HiSfM.num_top_bridges", h.skeleton.num_top_bridges,
        "Extra verified top-weight bridges after the trees");
  visit("--HiSfM.num_backup_bridges", h.skeleton.num_backup_bridges,
        "Verified backup bridges per weak tree bridge");
  visit("--HiSfM.weak_link_max_inliers",
        h.skeleton.weak_link_max_inliers,
        "Tree bridges with fewer inliers are weak links");
  visit("--HiSfM.restore_connectivity",
        h.skeleton.restore_connectivity,
        "Repair the trees' union to K-edge-connectivity across "
        "minimum cuts");
  visit("--HiSfM.fallback_threshold", h.skeleton.fallback_threshold,
        "Communities the trees leave apart are joined through the "
        "best-scoring bridge already scored if it reaches this "
        "(>= verify_threshold: off)");
  visit("--HiSfM.max_cycle_rotation_deg", h.skeleton.max_cycle_rotation_deg,
        "A bridge closing a cycle with the skeleton is taken only if the "
        "cycle's rotations compose within this (degrees; 0: off; verifiers "
        "that report no rotations, e.g. scores: and command:, skip it)");
  visit("--HiSfM.near_miss_vote", h.skeleton.near_miss_vote,
        "Refuse a bridge joining two parts when the bridges rejected "
        "between them with scores in [fallback_threshold, "
        "verify_threshold) that turn its cycle beyond "
        "max_cycle_rotation_deg outweigh it and those that agree with it "
        "(no effect when the two thresholds are equal, as by default)");
  visit("--HiSfM.peer_vote_size", h.skeleton.peer_vote_size,
        "Refuse a bridge joining two parts (beyond the rank tiers, scored "
        "below redundant_threshold) when, of up to this many of the "
        "heaviest bridges between them not rejected, those that turn its "
        "cycle beyond max_cycle_rotation_deg outweigh it and those that "
        "agree with it (stored two-view rotations, nothing scored; 0: off)");
  visit("--HiSfM.rank_tiers", h.skeleton.rank_tiers,
        "Trees take bridges by neighbour rank tiers 1..N before weight "
        "(0: by weight, as Algorithm 1)");
  visit("--HiSfM.max_bridge_rank", h.skeleton.max_bridge_rank,
        "Leave out bridges beyond this neighbour rank of either image "
        "(0: keep every rank)");
  visit("--HiSfM.intra_consistent_weights",
        h.skeleton.intra_consistent_weights,
        "Join a community's skeletal images by weights scaled by the share "
        "of inliers that agree with the pose the verifier accepts (builtin)");
  visit("--HiSfM.leaf_edges", h.leaves.leaf_edges,
        "Edges per leaf to skeletal images of its community");
  visit("--HiSfM.leaf_leaf_edges", h.leaves.leaf_leaf_edges,
        "Extra leaf-to-leaf edges per leaf inside its community");
  visit("--HiSfM.verifier", o->verifier.verifier,
        "Bridge verifier: builtin, none, scores:FILE, command:CMD");
  visit("--HiSfM.trusted_threshold",
        o->verifier.verified_hierarchy.trusted_edges.threshold,
        "A trusted edge (community, intra-community or leaf edge) "
        "scoring below this is removed and the hierarchy rebuilt "
        "(builtin verifier; others with --HiSfM.judge_trusted_edges)");
  visit("--HiSfM.trusted_rounds",
        o->verifier.verified_hierarchy.trusted_edges.max_rounds,
        "Rebuilds of the hierarchy without rejected trusted edges, at "
        "most");
  visit("--HiSfM.trusted_keep_rank",
        o->verifier.verified_hierarchy.trusted_keep_rank,
        "builtin verifier: a trusted edge among that many strongest pairs "
        "of both its images is kept whatever its score (0: every one is "
        "judged)");
  visit("--HiSfM.judge_trusted_edges", o->verifier.judge_trusted_edges,
        "Verifiers other than builtin (which always does): score the "
        "trusted edges too, not only the bridges");
  visit("--HiSfM.support_edges",
        o->verifier.verified_hierarchy.support_edges,
        "builtin and plug-in (scores:, command:) verifiers: each image's "
        "strongest pairs that pass --HiSfM.support_threshold also serve the "
        "reconstruction");
  visit("--HiSfM.support_threshold",
        o->verifier.verified_hierarchy.support_threshold,
        "builtin and plug-in verifiers: minimum score of a support edge");
  visit("--HiSfM.clean_inliers",
        o->verifier.verified_hierarchy.clean_inliers,
        "builtin verifier: reconstruct each edge from the inliers "
        "that agree with the geometry its test accepted");
  visit("--HiSfM.clean_plugin_inliers", o->verifier.clean_plugin_inliers,
        "plug-in verifiers: reconstruct each edge from the inliers that "
        "agree with the geometry the builtin edge test accepts");
  visit("--HiSfM.clean_error_factor",
        o->verifier.multiview.edge_test.inlier_error_factor,
        "Cleaning (--HiSfM.clean_inliers, --HiSfM.clean_plugin_inliers): "
        "an inlier is kept within this many times the pose's support "
        "error of the joined geometry");
  visit("--HiSfM.burstiness_weights",
        o->verifier.burstiness_weights,
        "builtin verifier: rank pairs by burstiness-weighted support "
        "instead of inlier count");
  visit("--HiSfM.verify_num_threads",
        o->verifier.multiview.num_threads,
        "builtin verifier: threads that judge pairs (0 = one per core; "
        "the scores do not depend on it)");
  visit("--HiSfM.min_relative_coverage",
        o->verifier.builtin.min_relative_coverage,
        "context verifier: a bridge's inlier coverage relative to "
        "each image's trusted pair that scores 0.5");
  visit("--HiSfM.coverage_grid_cells",
        o->verifier.builtin.grid_cells,
        "context verifier: grid cells along the longer image side");
  visit("--HiSfM.filter_pairs", o->verifier.filter_pairs,
        "Remove pairs explained by repeated structure before the "
        "hierarchy (context verifier only)");
  visit("--HiSfM.filter_top_pairs", o->filter_top_pairs,
        "The pair filter judges each image's this many strongest "
        "pairs (0 = all)");
  auto& pf = o->verifier.pair_filter;
  visit("--HiSfM.filter_min_distinctive_ratio",
        pf.min_distinctive_ratio,
        "Pair filter: distinctive inliers needed, as a fraction of "
        "the expected number");
  visit("--HiSfM.filter_distinctive_significance",
        pf.distinctive_significance,
        "Pair filter: Poisson significance of a distinctive "
        "shortfall");
  visit("--HiSfM.filter_min_three_view_consistency",
        pf.min_three_view_consistency,
        "Pair filter: fraction of inliers consistent in three views");
  visit("--HiSfM.filter_num_third_views", pf.num_third_views,
        "Pair filter: third views tried per image");
  visit("--HiSfM.filter_num_threads", pf.num_threads,
        "Pair filter: threads of the three-view test (0 = one per "
        "core)");
  visit("--HiSfM.filter_min_relative_coverage",
        pf.min_relative_coverage,
        "Pair filter: coverage relative to the image's best-covering "
        "strong pair");
  visit("--HiSfM.min_distinctive_ratio",
        o->verifier.builtin.min_distinctive_ratio,
        "context verifier: distinctive inliers ratio scoring 0.5");
  visit("--HiSfM.distinctive_significance",
        o->verifier.builtin.distinctive_significance,
        "context verifier: significance of a distinctive shortfall");
  visit("--HiSfM.verifier_scan_memory_mb",
        o->verifier.builtin.max_scan_memory_mb,
        "context verifier: MiB for what the tracks' read records of "
        "the bridges (beyond it, bridges are read when asked for)");
  visit("--HiSfM.verifier_batch_size", o->verifier.command_batch_size,
        "Bridges per call of a command verifier");
  visit("--HiSfM.attach_refine_focal_length", o->attach_refine_focal_length,
        "Attach run: refine focal lengths (the sequence pass's chain does "
        "not)");
  visit("--HiSfM.attach_local_only", o->attach_local_only,
        "Attach leaves with local bundle adjustment only, then one "
        "global bundle adjustment");
  visit("--HiSfM.scaffold_segment_images", o->scaffold_segment_images,
        "Reconstruct a larger scaffold in overlapping segments of at most "
        "this many images, merged through their shared images (0, or "
        "--HiSfM.merge_sub_models 0: one run)");
  visit("--HiSfM.scaffold_segment_overlap", o->scaffold_segment_overlap,
        "Images consecutive scaffold segments share");
  visit("--HiSfM.scaffold_ba_global_ratio",
        o->scaffold_ba_global_ratio,
        "Scaffold: growth in images or points between global bundle "
        "adjustments (colmap's default 1.1)");
  visit("--HiSfM.scaffold_ba_global_max_refinements",
        o->scaffold_ba_global_max_refinements,
        "Scaffold: repetitions of each global bundle adjustment "
        "(colmap's default 5)");
  visit("--HiSfM.ba_global_function_tolerance",
        o->ba_global_function_tolerance,
        "Both colmap runs: relative cost change that ends a global "
        "bundle adjustment (colmap's default 0)");
  visit("--HiSfM.ba_local_max_refinements",
        o->ba_local_max_refinements,
        "Both colmap runs: repetitions of each local bundle "
        "adjustment (colmap's default 2)");
  visit("--HiSfM.global_bundle_adjustment",
        o->global_bundle_adjustment,
        "Run an extra colmap bundle_adjuster at the end");
  visit("--HiSfM.refine_with_sequence_pairs", o->refine_with_sequence_pairs,
        "After the sequence pass: re-triangulate each scaffold segment from "
        "the pairs the pass checked and bundle-adjust it before the merge");
  visit("--HiSfM.trust_sequence_checks", o->trust_sequence_checks,
        "After the sequence pass: take the pairs it checked and kept as "
        "verified instead of asking the verifier about them");
  visit("--HiSfM.scaffold_from_sequence_chain", o->scaffold_from_sequence_chain,
        "After the sequence pass: start the scaffold from its chain model, "
        "refined, instead of reconstructing it again");
  visit("--HiSfM.refined_attach_ba_global_max_num_iterations",
        o->refined_attach_ba_global_max_num_iterations,
        "Attach run from refined scaffold segments: iterations of its "
        "global bundle adjustment (0: colmap's default 50)");
  visit("--HiSfM.min_model_size", o->min_model_size,
        "Components with fewer images are not reconstructed");
  visit("--HiSfM.merge_sub_models", o->merge_sub_models,
        "Merge colmap's sub-models of a component that share registered "
        "images instead of keeping the largest");
  visit("--HiSfM.merge_min_inliers", o->merge.min_inliers,
        "Shared 3D points that must agree to merge a sub-model");
  visit("--HiSfM.merge_min_inlier_ratio", o->merge.min_inlier_ratio,
        "Share of the shared 3D points that must agree to merge a "
        "sub-model");
  visit("--HiSfM.reseed_rounds", o->reseed_rounds,
        "Rounds of new models on the images left unregistered, merged "
        "into the component's model (0: off)");
  visit("--HiSfM.join_separate_models", o->join_separate_models,
        "Join models of the scaffold or the re-seeding that share no image "
        "with the component's model through the matched 3D points of the "
        "edges between them");
  visit("--HiSfM.join_min_inliers", o->join.min_inliers,
        "Matched 3D points that must agree to join a separate model");
  visit("--HiSfM.join_min_inlier_ratio", o->join.min_inlier_ratio,
        "Share of the matched 3D points that must agree to join a "
        "separate model");
  visit("--colmap_path", o->colmap.colmap_path,
        "The colmap executable");
}

}  // namespace

void AddHierarchicalMapperFlags(CLI::App& app,
                                HierarchicalMapperOptions* options) {
  ForEachMapperFlag(options, [&](const std::string& flag, auto& option,
                                 const std::string& help) {
    app.add_option(flag, option, help)->capture_default_str();
  });
}

void CheckOptionFlags(const OptionFlagMap& flags,
                      const std::function<void()>& check) {
  try {
    check();
  } catch (const OptionError& e) {
    auto it = flags.find(e.field());
    if (it == flags.end()) throw;
    throw e.WithName(it->second);
  }
}

OptionFlagMap MapperOptionFlags(const HierarchicalMapperOptions& options) {
  OptionFlagMap flags;
  // Only the options' addresses are taken: nothing is written.
  ForEachMapperFlag(const_cast<HierarchicalMapperOptions*>(&options),
                    [&](const std::string& flag, const auto& option,
                        const std::string&) { flags[&option] = flag; });
  return flags;
}

void AddMapperPathFlags(CLI::App& app, MapperPaths* paths) {
  app.add_option("--database_path", paths->database_path, "COLMAP database")
      ->required();
  app.add_option("--image_path", paths->image_path, "Folder of the photos")
      ->required();
  app.add_option("--output_path", paths->output_path,
                 "Output folder (missing or empty)")
      ->required();
  app.add_option("--work_path", paths->work_path,
                 "Intermediate files (default OUTPUT_work)");
}

void AddPoseEvaluationFlags(CLI::App& app, PoseEvaluationOptions* options,
                            OptionFlagMap* flags) {
  AddOptionFlag(app, flags, "--verdict_threshold_deg",
                options->verdict_threshold_deg,
                "Pair error threshold of the verdict (degrees)")
      ->capture_default_str();
  AddOptionFlag(app, flags, "--min_correct_pair_fraction",
                options->min_correct_pair_fraction,
                "Fraction of pairs within the threshold needed for "
                "'correct'")
      ->capture_default_str();
  AddOptionFlag(app, flags, "--center_threshold", options->center_threshold,
                "An aligned camera centre is right within this fraction of "
                "the scene extent")
      ->capture_default_str();
  AddOptionFlag(app, flags, "--min_correct_center_fraction",
                options->min_correct_center_fraction,
                "Fraction of camera centres within --center_threshold "
                "needed for 'correct' (0: no centre check; not checked "
                "with fewer than 3 common images)")
      ->capture_default_str();
  AddOptionFlag(app, flags, "--require_all_registered",
                options->require_all_registered,
                "'correct' needs every reference image registered")
      ->capture_default_str();
  AddOptionFlag(app, flags, "--min_model_size", options->min_model_size,
                "Models with at least this many reference images count as "
                "parts of an oversplit result")
      ->capture_default_str()
      ->check(CLI::Range(0, 1000000));
  AddOptionFlag(app, flags, "--alignment_inlier_threshold",
                options->alignment.inlier_threshold,
                "Centre alignment inlier distance, fraction of the scene "
                "extent")
      ->capture_default_str();
}

void AddLogLevelFlag(CLI::App& app, std::string* level) {
  app.add_option("--log_level", *level,
                 "trace, debug, info, warn, error or off")
      ->capture_default_str()
      ->check(CLI::IsMember({"trace", "debug", "info", "warn", "error", "off"}));
  app.parse_complete_callback([level] { SetLogLevel(*level); });
}

std::map<std::string, std::string> ReadMapperEntries(const std::string& path) {
  std::map<std::string, std::string> entries;
  std::istringstream in(ReadTextFile(path));
  std::string line;
  while (std::getline(in, line)) {
    const size_t eq = line.find('=');
    if (line.rfind("Mapper.", 0) != 0 || eq == std::string::npos) continue;
    std::string value = line.substr(eq + 1);
    if (value.size() >= 2 && value.front() == '"' && value.back() == '"') {
      value = value.substr(1, value.size() - 2);
    }
    entries[line.substr(0, eq)] = value;
  }
  return entries;
}

std::vector<std::string> TakeMapperPassThrough(
    const std::vector<std::string>& remaining,
    const std::map<std::string, std::string>& file_entries) {
  std::vector<std::string> out;
  std::set<std::string> seen;
  for (size_t i = 0; i < remaining.size(); ++i) {
    const std::string& arg = remaining[i];
    std::string name = arg;
    std::string value;
    if (arg.rfind("--Mapper.", 0) == 0) {
      const size_t eq = arg.find('=');
      if (eq != std::string::npos) {
        name = arg.substr(0, eq);
        value = arg.substr(eq + 1);
      } else {
        ThrowUnless(i + 1 < remaining.size(),
                    StrCat("missing value for ", arg));
        value = remaining[++i];
      }
    } else if (file_entries.count(arg) > 0) {
      // A key of the options file that no flag has (CLI11 passes its name).
      name = "--" + arg;
      value = file_entries.at(arg);
    } else {
      throw Error(StrCat("unknown argument '", arg, "' (see -h)"));
    }
    // The command line comes before the options file: its value wins.
    if (!seen.insert(name).second) continue;
    out.push_back(name);
    out.push_back(value);
  }
  return out;
}

int ParseCommandLine(CLI::App& app, int argc, char** argv) {
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    if (e.get_exit_code() == 0) return app.exit(e);  // Help.
    std::string message = e.what();
    std::replace(message.begin(), message.end(), '\n', ' ');
    std::fprintf(stderr, "error: %s (see -h)\n", message.c_str());
    return 1;
  }
  return -1;
}

void PrepareMapperCommand(CLI::App& app, HierarchicalMapperOptions* options,
                          std::string* log_level) {
  AddHierarchicalMapperFlags(app, options);
  AddLogLevelFlag(app, log_level);
  app.set_config("--project_path", "",
                 "Options file (INI), such as the hisfm_options.ini a run "
                 "writes; flags on the command line win");
  // "HiSfM.top_k" is one flag's name, not option top_k of a section HiSfM.
  app.get_config_formatter_base()->parentSeparator('/');
  app.allow_extras();
  app.allow_config_extras(CLI::config_extras_mode::capture);
}

void CheckMapperOptions(const HierarchicalMapperOptions& options) {
  CheckOptionFlags(MapperOptionFlags(options), [&] { options.Check(); });
}

int ParseMapperCommand(CLI::App& app, int argc, char** argv,
                       HierarchicalMapperOptions* options,
                       std::string* log_level) {
  PrepareMapperCommand(app, options, log_level);
  if (const int code = ParseCommandLine(app, argc, argv); code >= 0) {
    return code;
  }
  const CLI::Option* project = app.get_config_ptr();
  options->mapper_args = TakeMapperPassThrough(
      app.remaining(), project->count() > 0
                           ? ReadMapperEntries(project->as<std::string>())
                           : std::map<std::string, std::string>());
  CheckMapperOptions(*options);
  return -1;
}

std::string OptionsRecord(CLI::App& app,
                          const std::vector<std::string>& mapper_args) {
  // Paths are recorded absolute, so that the file works from anywhere; not
  // the colmap executable, which is looked up on PATH.
  for (CLI::Option* option : app.get_options()) {
    const std::string name = option->get_name();
    if (name.size() < 5 || name.compare(name.size() - 5, 5, "_path") != 0 ||
        name == "--colmap_path" || option->count() == 0 ||
        option == app.get_config_ptr()) {
      continue;
    }
    const std::string value = option->as<std::string>();
    if (value.empty()) continue;
    option->clear();
    option->add_result(NormalizePath(value));
  }
  std::string record = app.config_to_str(true, false);
  for (size_t i = 0; i + 1 < mapper_args.size(); i += 2) {
    record += StrCat(mapper_args[i].substr(2), "=", mapper_args[i + 1], "\n");
  }
  return record;
}

}  // namespace hisfm
