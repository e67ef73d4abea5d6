// Coarse-to-fine reconstruction on the hierarchy with COLMAP as back-end.
//
// HiSfM paper, Sec. III-D: incremental SfM on the skeleton only (the
// scaffold), then registration of the leaves using only the hierarchy's
// edges (PnP, triangulation, local bundle adjustment, repeated until nothing
// more registers), then one global bundle adjustment. Each stage is a
// `colmap` call on a filtered copy of the database:
//   scaffold: colmap mapper --image_list_path <skeleton images> on E_s;
//   attach:   colmap mapper --input_path <scaffold> on E_H = E_s + E_l;
//   refine:   colmap bundle_adjuster.
// Two additions for failing soft: sub-models that colmap splits a stage
// into are merged through their shared images (model_merge.h), and images
// left unregistered get new models on E_H (and reserve edges) that are
// merged the same way and attached again.
// One model per connected component of the hierarchy.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "hisfm/graph/hierarchy.h"
#include "hisfm/recon/colmap_runner.h"
#include "hisfm/recon/model_merge.h"
#include "hisfm/recon/sequence_pass.h"
#include "hisfm/verify/verifier_factory.h"

namespace hisfm {

struct HierarchicalMapperOptions {
  /// Verified pairs with fewer inliers are ignored (COLMAP's
  /// --Mapper.min_num_matches default).
  int min_num_matches = 15;
  /// The sequence pass (sequence_pass.h): with images named in capture
  /// order, pairs that disagree with the reconstructed chain of consecutive
  /// pairs are removed before the hierarchy is built.
  SequencePassOptions sequence;
  /// Communities, skeleton and leaves.
  HierarchyOptions hierarchy;
  /// The bridge verifier.
  VerifierOptions verifier;
  /// The colmap executable.
  ColmapRunnerOptions colmap;
  /// Attach the leaves with local bundle adjustment only: colmap's periodic
  /// global bundle adjustments are switched off for the attach run, whose
  /// final global bundle adjustment is then the single one of the paper.
  bool attach_local_only = true;
  /// Attach run on a scaffold: refine the focal lengths in its bundle
  /// adjustments (colmap's --Mapper.ba_refine_focal_length). The sequence
  /// pass's chain turns it off: with only consecutive pairs the final global
  /// adjustment trades focal length against a bend of a long street
  /// (facade_street_150_s7: the scaffold's pairs 0.38 degrees off in
  /// rotation at the median, 3.65 after the attach run, 0.44 without
  /// refining the focal length; the scaffold has refined it already). An
  /// explicit --Mapper flag wins.
  bool attach_refine_focal_length = true;
  /// A scaffold of more skeletal images is reconstructed in overlapping
  /// segments of at most this many (graph/graph_segments.h: windows of a
  /// banded order of the skeleton's edges), each by its own colmap run, and
  /// their models are merged through the images they share, as the sequence
  /// pass's chain is: incremental SfM's global bundle adjustments make one
  /// run grow faster than its images (a 5,000-image street's 4,095-image
  /// scaffold had 3,071 registered after 87 minutes). 1,000 leaves every
  /// scaffold measured up to 1,000 images in one run, as before; smaller
  /// segments are not measured. 0 = always one run; so is merge_sub_models
  /// = false, as segments need their merge.
  int scaffold_segment_images = 1000;
  /// Images consecutive scaffold segments share (at least): a skeleton's
  /// window of the banded order is wider than a chain's, so more than the
  /// chain's 30; not tuned.
  int scaffold_segment_overlap = 50;
  /// Scaffold run: colmap's periodic global bundle adjustment runs when the
  /// model has grown by this factor in images or points since the last one
  /// (colmap's --Mapper.ba_global_images_ratio / points_ratio, default 1.1).
  /// Local bundle adjustment still follows every registration, and the
  /// attach run ends with a full global one, so the scaffold's intermediate
  /// global adjustments can be sparser. An explicit --Mapper flag wins.
  double scaffold_ba_global_ratio = 1.4;
  /// Scaffold run: global bundle adjustments repeated after filtering
  /// outliers at most this many times (colmap's
  /// --Mapper.ba_global_max_refinements, default 5). An explicit --Mapper
  /// flag wins.
  int scaffold_ba_global_max_refinements = 2;
  /// Both runs: local bundle adjustment is repeated after filtering outliers
  /// at most this many times (colmap's --Mapper.ba_local_max_refinements,
  /// default 2). An explicit --Mapper flag wins.
  int ba_local_max_refinements = 1;
  /// Both runs, and the refinements' bundle_adjuster
  /// (refine_with_sequence_pairs, as --BundleAdjustment.function_tolerance):
  /// global bundle adjustment stops when the relative change of
  /// its cost falls below this. colmap's --Mapper.ba_global_function_tolerance
  /// defaults to 0: an adjustment whose cost no longer moves keeps iterating
  /// up to its 50-iteration cap, slowly straightening weak low-frequency
  /// modes (long camera chains). Measured on 300-image synthetic streets
  /// with the other defaults, 1e-7 halves the mapper time and raises the
  /// median pair error from 0.12 to 0.16-0.29 degrees; 0 restores colmap's
  /// behaviour. An explicit --Mapper flag wins.
  double ba_global_function_tolerance = 1e-7;
  /// Run an extra `colmap bundle_adjuster` after the attachment (the attach
  /// run already ends with a global bundle adjustment).
  bool global_bundle_adjustment = false;
  /// When the sequence pass cleaned the database and the scaffold runs in
  /// segments (scaffold_segment_images), each segment's model is
  /// re-triangulated, poses fixed (`colmap point_triangulator`), from the
  /// skeleton's edges and every pair the pass checked against its chain
  /// between the segment's images (both in one chain model; those kept
  /// agree with it; the trusted edges the hierarchy's verifier rejected
  /// left out), the skeleton's points kept and extended, then adjusted by
  /// one `colmap bundle_adjuster` (colmap's defaults, up to 100 iterations,
  /// but ba_global_function_tolerance: on the 1,000-image street, seed 1,
  /// the chain's scaffold took 101 iterations and 138 s with colmap's
  /// tolerance 0, whose last 90 moved the cost by 0.01%, and 65
  /// iterations with 1e-7, every pair within 5 degrees either way; with the
  /// default segments of at most 1,000 images colmap's
  /// solver is still direct), before the segments merge. The
  /// skeleton's edges alone (1.5 a image on a street) give tracks so short
  /// that a long street's bend is almost free: on the 5,000-image street one
  /// segment of 859 images bent by 5.6 degrees end to end (97.6% of its
  /// pairs within 5 degrees, median 1.74), and 200 more bundle-adjustment
  /// iterations on its own tracks moved its cost by 2e-6 px and left it
  /// bent; re-triangulated from the pass's pairs and adjusted, it converged
  /// to a median of 0.18 degrees in 79 s, and the merged scaffold went from
  /// 93.6% to 100.0% of pairs within 5 degrees (docs/decisions.md,
  /// twenty-seventh session). A scaffold in one run is not refined (the
  /// attach run's global adjustment follows). Without the pass no pair
  /// outside the hierarchy was checked, and the step is skipped.
  bool refine_with_sequence_pairs = true;
  /// When the sequence pass cleaned the database and kept no loop closure,
  /// the pairs its transfer test kept between images of one chain model are
  /// taken as verified. A pass that kept closures had a chain that drifted
  /// past its own test, and its agreement proves less: on
  /// block_loop_1000_s2 (held-out, 11 closures) trusting its pairs left the
  /// loop bent, 67.3% of pairs within 5 degrees with or without the
  /// closures themselves, against 99.1% with the verifier
  /// (docs/decisions.md, twenty-eighth session). The
  /// hierarchy does not ask the verifier about them (score 1,
  /// no rejection by score, no inlier cleaning; the skeleton's cycle check,
  /// SkeletonOptions, still applies to them as bridges). The
  /// pass tested each of them, match by match, against a multi-view model
  /// of the sequence, which two views cannot give; only the pairs it could
  /// not test (an image outside its models) are verified as Algorithm 1
  /// says. On the 1,000-image street (seed 1) the builtin verifier had
  /// judged 1,763 such pairs in 55 s; on the 5,000-image one the hierarchy
  /// took 789 s (docs/decisions.md, twenty-eighth session).
  bool trust_sequence_checks = true;
  /// When the sequence pass cleaned the database and one of its chain
  /// models registers every skeletal image of a component, that model
  /// (without the component's other images) is the scaffold instead of a
  /// new colmap mapper run on the skeleton: cut into the scaffold's
  /// segments (scaffold_segment_images; one when it is smaller), each
  /// refined as a scaffold segment is (refine_with_sequence_pairs, which it
  /// needs: re-triangulated from the skeleton's edges and the pass's
  /// checked pairs, adjusted to convergence), and merged. The leaves are
  /// then attached on the hierarchy's edges as Algorithm 1 says. The pass
  /// has reconstructed the whole sequence once already, and every pair left
  /// in the database agrees with it; the second reconstruction was most of
  /// the mapper's time after the pass (docs/decisions.md, twenty-eighth
  /// session). A segment whose refinement fails is merged as the chain has
  /// it (logged). Not when the pass kept loop closures: the chain then
  /// drifted past the transfer test (on block_loop_1000_s2, held-out, its
  /// closures landed 21 camera spacings off), and a re-triangulation with
  /// the chain's poses fixed cannot bring the loop's ends together; the
  /// scaffold is then reconstructed by colmap mapper from the hierarchy,
  /// closures included.
  bool scaffold_from_sequence_chain = true;
  /// The attach run from a scaffold whose segments were all refined
  /// (refine_with_sequence_pairs) stops its global bundle adjustment after
  /// this many iterations (colmap's --Mapper.ba_global_max_num_iterations,
  /// default 50): the scaffold is already adjusted to convergence, and each
  /// leaf gets its local adjustment. On the 5,000-image street 10 gave the
  /// model that 50 gave (100.0% of pairs within 5 degrees, median 0.919
  /// against 0.922 degrees) with an attach run of 328 s instead of 1,568 s
  /// (docs/decisions.md, twenty-seventh session). 0 = colmap's default. An
  /// explicit --Mapper flag wins.
  int refined_attach_ba_global_max_num_iterations = 10;
  /// The pair filter (VerifierOptions::filter_pairs) judges the union of
  /// every image's this many strongest pairs (0 = every pair).
  int filter_top_pairs = 20;
  /// Components with fewer images are not reconstructed.
  int min_model_size = 3;
  /// When colmap splits a scaffold (or a model started from scratch) into
  /// sub-models, merge those that share registered images into the largest
  /// (model_merge.h) instead of dropping them. False also turns off
  /// re-seeding (reseed_rounds), whose models are merged the same way.
  bool merge_sub_models = true;
  /// How sub-models are merged.
  ModelMergeOptions merge;
  /// Rounds of re-seeding the images still unregistered after the attach
  /// stage: new colmap models on them and their registered neighbours (the
  /// hierarchy's and reserve edges only), merged into the component's model
  /// where they share registered images, then attached again; a round runs
  /// only while the previous one registered more. Every round's models that
  /// could not be merged (and the scaffold's) are joined through edges
  /// (join_separate_models) or written as further models. 0 turns it off.
  int reseed_rounds = 2;
  /// Join the models of the scaffold or the re-seeding that could not be
  /// merged (they share no image with the component's model) when the component's hierarchy and reserve
  /// edges between them match 3D points of both that one similarity maps
  /// onto each other (MergeThroughMatches); the joined model is then refined
  /// with the rest. False writes them as further models.
  bool join_separate_models = true;
  /// How separate models are joined (MergeThroughMatches's thresholds; its
  /// own, as the points there fix all seven degrees of freedom where a
  /// shared image's poses fix six). The share of agreeing points stays at
  /// 0.5 here: the merge's 0.7 was measured on merges through shared images
  /// only.
  ModelMergeOptions join = [] {
    ModelMergeOptions options;
    options.min_inlier_ratio = 0.5;
    return options;
  }();
  /// Extra `--Mapper.*` arguments passed to both colmap mapper calls.
  std::vector<std::string> mapper_args;

  void Check() const;
};

/// Paths of one run.
struct MapperPaths {
  std::string database_path;
  std::string image_path;
  /// Final models go to output_path/0, /1, ...: each component's model,
  /// then the models of a component's scaffold or re-seeding that could
  /// not be joined to it (the summary's "separate_from" names the
  /// component's model); must be missing or empty.
  std::string output_path;
  /// Intermediate databases, scaffolds and logs (kept for inspection);
  /// default output_path + "_work" when empty.
  std::string work_path;
  /// Text recording the options used (the command line's INI dump), written
  /// to output_path/hisfm_options.ini when not empty.
  std::string options_record;
};

/// Runs the whole pipeline. Returns the summary that is also written to
/// output_path/hisfm_summary.json. Throws hisfm::Error on bad input or a
/// failing colmap call; nothing is left under output_path then.
nlohmann::json RunHierarchicalMapper(const MapperPaths& paths,
                                     const HierarchicalMapperOptions& options);

/// Builds only the hierarchy of a database (view graph, communities,
/// verified skeleton, leaves) and returns HierarchyToJson plus timings. The
/// sequence pass is not run (it needs colmap): the hierarchy is the one the
/// mapper builds with --HiSfM.sequence_prior off.
nlohmann::json ComputeViewGraphJson(const std::string& database_path,
                                    const std::string& image_path,
                                    const HierarchicalMapperOptions& options);

}  // namespace hisfm
