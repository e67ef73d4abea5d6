// The sequence pass (graph/sequence_chain.h): when the image names give the
// capture order, the chain of consecutive pairs is reconstructed first, its
// models are joined through the verified pairs between them (those near in
// the capture order first) where their matched 3D points agree on one
// similarity (MergeThroughMatches) or, where doppelgangers outvote the true
// pairs, by the proposed join that conflicts
// least with their unique points (recon/conflict_join.h), and every
// verified pair whose images one of the chain's models holds is put to the
// transfer test against it (verify/model_agreement.h). A pair that agrees
// keeps only its matches that agree; the others are removed, except a
// loop's closures, which the chain's drift can push past the test and which
// are found among them by the same conflict with the unique points
// (close_loops_by_conflict). The result is a
// cleaned copy of the database that the rest of the mapper reads: far pairs
// of a sequence are its loop closures, kept only when they agree with the
// odometry, as a SLAM system keeps them (graph/sequence_chain.h cites the
// idea). Pairs with an image outside the chain's models are left to the
// hierarchy's verification.
//
// Against Algorithm 1 of the HiSfM paper this adds a step before it (the
// paper has no order prior); the hierarchy, its verification and the
// coarse-to-fine reconstruction then run unchanged on the cleaned database.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "hisfm/graph/sequence_chain.h"
#include "hisfm/io/model.h"
#include "hisfm/recon/conflict_join.h"
#include "hisfm/recon/model_merge.h"
#include "hisfm/verify/model_agreement.h"
#include "hisfm/verify/unique_points.h"

namespace hisfm {

struct SequencePassOptions {
  /// Whether and how the name order is used.
  SequenceOptions sequence;
  /// The chain is reconstructed in overlapping segments of at most this
  /// many images (ChainSegments), each by its own mapper run, and their
  /// models are merged through the images they share (MergeModels): an
  /// incremental mapper's global bundle adjustments make one run on a long
  /// chain grow faster than its length (a 5,000-image street's chain had
  /// registered 1,181 images after 10 minutes). 0 reconstructs it in one
  /// run.
  int chain_segment_images = 300;
  /// Images consecutive segments share (at least).
  int chain_segment_overlap = 30;
  /// Segments reconstructed side by side, each run on a thread of its own
  /// (their models merge in the chain's order whatever order they finish
  /// in). colmap's mapper keeps about 1.3 of 2 cores busy on a segment (the
  /// 1,000-image street, seed 1: 356 s of CPU in 271 s), so two at a time
  /// fill them; 1 runs them one after another.
  int chain_segment_parallel_runs = 2;
  /// How the segments' models are merged through their shared images.
  ModelMergeOptions segment_merge;
  /// The transfer test of each pair against the chain's models.
  ModelAgreementOptions agreement;
  /// Clean only when the chain's pieces were joined into one model. Where
  /// they could not be (two streets whose chain breaks where the capture
  /// jumps, and whose pairs agree on no one similarity), how the pieces
  /// relate is left to the hierarchy on the input's pairs: cleaning inside
  /// the pieces alone left crossing_streets_150_s3 folded and s5 and s8
  /// split in two (tuning and held-out; docs/decisions.md, twenty-first
  /// session).
  bool require_one_model = true;
  /// Models of one unbroken stretch of the chain are first joined through
  /// their near pairs alone: pairs at most this many places apart in the
  /// name order with a link between every two consecutive images between
  /// them (NearChainPairs). The chain's mapper can split where a link
  /// carries few tracks on (block_loop_1000_s2, held-out: a link with 137
  /// matches, 1 of them a 3D point in both models), and then every other
  /// pair between the pieces votes, doppelgangers included (there 137,161
  /// pairs, whose best similarity had 924 of 1,189,767 matched points
  /// agree). Two places, as the capture order vouches only for the nearest:
  /// on the instances at hand (40 to 1,000 images, both halves) at most 0.4%
  /// of the pairs one place apart are doppelgangers by their labels, up to
  /// 35% of those two apart (block loops, tuning) and up to 73% of those
  /// three apart (facade streets, held-out); 0 turns this round off
  /// (docs/decisions.md, twenty-third session).
  int near_join_window = 2;
  /// How the near pairs join: most of their matched points must agree, as
  /// in the mapper's merges (a repeated street's doppelgangers can lie
  /// within the window too, each voting for a join of its own).
  ModelMergeOptions near_join = [] {
    ModelMergeOptions options;
    options.min_inlier_ratio = 0.7;
    options.min_inliers = 30;
    return options;
  }();
  /// Models that the pairs between them cannot join (their doppelgangers
  /// outvote the true pairs) are joined by the proposal that conflicts
  /// least with their unique points, if it clears conflict_join's bars
  /// (recon/conflict_join.h). On crossing_streets_1000_s3 (tuning) the two
  /// streets' pieces gave 1,059,179 matched points whose best similarity
  /// laid one street onto the other (90 degrees off, 3,087 agreeing); the
  /// true join had 879, and 145 pairs voted for it against 1,000 to 1,135
  /// for each of the leading wrong ones (docs/decisions.md, twenty-second
  /// session).
  bool join_by_conflict = true;
  /// Which points of a chain model are unique (join_by_conflict).
  UniquePointOptions unique_points;
  /// The bars of a join by conflict.
  ConflictJoinOptions conflict_join;
  /// How the chain's models are joined through the pairs between them. The
  /// share of agreeing points is lower than the mapper's join (0.5): every
  /// verified pair between two stretches of a repeated street votes here,
  /// doppelgangers included, where the mapper's join sees only the
  /// hierarchy's edges.
  ModelMergeOptions join = [] {
    ModelMergeOptions options;
    options.min_inlier_ratio = 0.2;
    options.min_inliers = 30;
    return options;
  }();
  /// Loop closures by conflict. A chain drifts: at the end of a loop its
  /// true closures can land far beyond the transfer test's tolerance (on
  /// block_loop_1000_s2, held-out, the 14 closures between the first and
  /// the last images land 21 camera spacings off, more than many of the
  /// facade's doppelgangers do), and a loop without its closures stays
  /// bent. The model is cut into the two halves of the chain's order; the
  /// pairs across them that the transfer test rejects (more than
  /// break_window places apart) propose joins of one half onto the other,
  /// as two pieces do in the join by conflict, and the voting pairs of the
  /// proposal that conflicts least with the unique points, if it clears the
  /// join by conflict's bars, are kept whole (docs/decisions.md,
  /// twenty-fourth session).
  bool close_loops_by_conflict = true;
  /// A loop closure clears conflict_join's bars, with up to this many
  /// proposed joins examined (a loop's drifted closures are a small family
  /// among the facade's shifts; on block_loop_1000_s2 the search went
  /// through 809 of them).
  int loop_closure_max_hypotheses = 2000;
  /// A loop closure corrects the chain's drift, which turns the chain
  /// little: the join of the halves may turn one by at most this angle
  /// (degrees). A join that turns it further maps a symmetric object's side
  /// onto its twin (180 degrees for a 2-fold symmetry, 90 for a 4-fold);
  /// the chains at hand drifted by at most 10 degrees
  /// (block_loop_1000_s2's 835-image piece: every pair within 10 degrees).
  double loop_closure_max_rotation_deg = 30.0;

  /// Throws hisfm::Error if an option is out of range.
  void Check() const;
};

/// What the pass did.
struct SequencePassResult {
  /// The name order, its tests and the chain's links.
  SequenceChain chain;
  /// True when the chain was reconstructed and pairs were judged.
  bool ran = false;
  /// Verified pairs of the input (with at least min_num_matches inliers).
  size_t num_input_pairs = 0;
  /// Segments the chain was reconstructed in (chain_segment_images).
  size_t num_segments = 0;
  /// The chain's models (after the segments' merge), and how many of them
  /// were joined into others.
  size_t num_models = 0;
  size_t num_joined = 0;
  /// Of those, the models joined through their near pairs
  /// (near_join_window).
  size_t num_joined_near = 0;
  /// Of those, the models joined by conflict (join_by_conflict).
  size_t num_joined_by_conflict = 0;
  /// Pairs the transfer test rejected and kept as loop closures
  /// (close_loops_by_conflict), with their input matches.
  size_t num_loop_closures = 0;
  std::vector<ImagePair> loop_closures;
  /// Images the chain's models registered.
  size_t num_registered = 0;
  /// Pairs with both images in one chain model, those removed (they
  /// disagree or have too few testable matches), and the inlier matches
  /// the kept ones lost.
  size_t num_judged = 0;
  size_t num_removed = 0;
  size_t num_matches_removed = 0;
  /// The cleaned database ("" when the pass did not run).
  std::string cleaned_database_path;
  /// The chain's models after the joins, the largest first (empty when the
  /// pass did not run). The mapper writes them instead of its own when its
  /// largest model registers fewer images than the first of them and its
  /// models no more images in all (the joins are not refined by a further
  /// bundle adjustment).
  std::vector<Reconstruction> chain_models;
  /// Why the pass did not run or stopped early ("" if it ran).
  std::string note;
  /// Wall time of the pass, the chain's reconstruction included.
  double seconds = 0.0;

  /// The summary's "sequence" entry.
  nlohmann::json ToJson() const;
};

/// Reconstructs a database holding only some of the chain's links (one
/// segment) into numbered models (the mapper without the sequence pass);
/// throws hisfm::Error when no model could be made. Called from up to
/// chain_segment_parallel_runs threads at once, each with a database path
/// of its own.
using ChainReconstructor = std::function<std::vector<Reconstruction>(
    const std::string& chain_database_path)>;

/// Runs the pass on the database at `database_path` (its pairs with at
/// least `min_num_matches` inliers) and writes the cleaned database under
/// `work_path`. A failing chain reconstruction cleans nothing (the result's
/// note says why). The input database is only read.
SequencePassResult RunSequencePass(const std::string& database_path,
                                   int min_num_matches,
                                   const std::string& work_path,
                                   const ChainReconstructor& reconstruct,
                                   const SequencePassOptions& options);

}  // namespace hisfm
