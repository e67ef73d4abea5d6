// Skeletal subgraph building by verified, greedy packing of edge-disjoint
// spanning trees over the community graph.
//
// HiSfM paper, Sec. III-B and Algorithm 1: bridges are verified pairs between
// different communities. For t = 1..K, Kruskal over the bridges by descending
// inlier count takes a bridge only if (i) it joins two different union-find
// sets of communities, (ii) its community pair was not used by an earlier
// tree (the diversity set U), and (iii) the disambiguator scores it at least
// tau. Verification is lazy: only bridges that pass (i) and (ii) are scored,
// and each at most once. Two deviations for the redundant bridges (every
// tree after the first and the extra bridges below): they need a stricter
// score (SkeletonOptions::redundant_threshold), and they are verified within
// a budget (redundant_budget_trees), because a street's chain of
// communities has no second spanning tree of true pairs and Algorithm 1
// would verify nearly every bridge looking for one. Greedy packing can fail to find K trees that exist;
// the union is then repaired across minimum cuts (Stoer-Wagner) so that it is
// K-edge-connected, as the paper's Tutte-Nash-Williams argument expects.
// Optional extra bridges (top-weight ones, and backups for weak links) are
// verified too. Every bridge that closes a cycle with the skeleton built so
// far (all but the first tree's) must also be loop consistent in rotation
// (SkeletonOptions::max_cycle_rotation_deg; an addition to Algorithm 1,
// checked before the bridge is scored, so it scores fewer pairs, not more).
// When the trees cannot span (every bridge between some communities scored
// below tau), the best-scoring bridges that were scored join what is left
// apart, if they reach a lower fallback threshold (failing soft: one model
// through its most trustworthy bridge, rather than pieces). Skeletal images
// of one community are then joined by intra-community edges, which the
// paper does not verify.
//
// A third deviation: the trees meet the bridges in tiers of neighbour rank
// before weight (SkeletonOptions::rank_tiers): a bridge among the few
// strongest pairs of both its images (mutual k-nearest neighbours, as the
// communities use k = 1) comes before a heavier one that is not.
//
// A fourth deviation: the tree that joins a community's skeletal images is
// weighed by the share of each pair's inliers that agree with the pose the
// scorer accepts for it (SkeletonOptions::intra_consistent_weights).
//
// A fifth deviation: a bridge that joins two parts held apart is refused
// when the bridges rejected between those parts with a score in
// [fallback_threshold, tau) (near misses) outweigh it and disagree with it
// in rotation around the cycles it closes with them
// (SkeletonOptions::near_miss_vote; no pair is scored for it).
//
// A sixth: the first tree verifies within a budget when there is a
// fallback (SkeletonOptions::first_tree_budget_trees); once it is spent,
// the near misses join what they can and the tree goes on at the fallback
// threshold.
//
// A seventh: a bridge beyond the rank tiers that joins two parts held
// apart with a score below the redundant threshold is refused when the
// heaviest bridges between the same parts, scored or not, outweigh it and
// disagree with it in rotation (SkeletonOptions::peer_vote_size).
//
// Kruskal is kept exact within that order (a deferral rule that was tried
// verified more bridges, not fewer: docs/decisions.md).
#pragma once

#include <map>
#include <vector>

#include "hisfm/graph/bridge_scorer.h"
#include "hisfm/graph/communities.h"
#include "hisfm/graph/view_graph.h"

namespace hisfm {

/// Why a bridge is in the skeleton.
enum class BridgeRole { kTree, kTopWeight, kBackup, kConnectivity, kFallback };

struct SkeletonOptions {
  /// Number of spanning trees K; 0 = max(1, round(n / images_per_tree)).
  int num_trees = 0;
  /// Images per tree for the automatic K (the paper: one tree per 300).
  int images_per_tree = 300;
  /// Minimum verifier score for a bridge to be taken (tau).
  double verify_threshold = 0.5;
  /// Minimum score of a bridge that adds redundancy rather than
  /// connectivity: the bridges of every tree after the first, backups,
  /// top-weight and connectivity bridges (the larger of this and
  /// verify_threshold applies). A deviation from Algorithm 1, which uses tau
  /// for every tree: the first tree already joins the communities, and a
  /// false redundant bridge folds the model as surely as a false tree
  /// bridge, while a missing one only costs robustness. In a street, whose
  /// community graph is a chain, the second tree can only be packed from
  /// long-range pairs, most of them doppelgangers, and at tau = 0.5 a
  /// calibrated score lets through up to half of what it meets.
  double redundant_threshold = 0.8;
  /// Verification budget of the redundant bridges, in spanning trees: after
  /// the first tree, the scorer is asked about at most
  /// redundant_budget_trees * max(1, K - 1) * (m - c) more bridges (m
  /// communities in c components of the community graph: the edges of a
  /// spanning forest); bridges that would need a new score beyond it are
  /// not taken, so later trees, connectivity repair, backups and top-weight
  /// bridges (in that order) share it and the last may get none. A free
  /// scorer (BridgeScorer::IsFree, e.g. --HiSfM.verifier none) has no
  /// budget. Speculative batches (max_verify_batch_size) count against it.
  /// Algorithm 1 verifies every bridge Kruskal meets, and once a later tree
  /// cannot span (a street's chain of communities has no second spanning
  /// tree of true pairs) it meets nearly all of them: this keeps the cost
  /// of redundancy to about one verification per edge it may add.
  double redundant_budget_trees = 1.0;
  /// Verification budget of the first tree, in spanning trees: it scores
  /// at most first_tree_budget_trees * (m - c) bridges at tau (speculative
  /// batches included). Once that is spent, the near misses met so far (in
  /// [fallback_threshold, tau)) join the parts they can, best score first,
  /// each subject to the near-miss vote, and the tree goes on at
  /// fallback_threshold without a budget, still lazily (as Algorithm 1 at
  /// tau = fallback_threshold); what it takes from then on has the role
  /// kFallback. 0 = no budget, as Algorithm 1. Only with a fallback
  /// (fallback_threshold < verify_threshold; at the defaults, 0.5 and 0.5,
  /// there is none and nothing changes) and a scorer that is not free. A
  /// deviation from Algorithm 1: with tau above the scores of the true
  /// bridges between two parts, Kruskal scans every bridge between them
  /// looking for one that passes (a 1,000-image street at tau = 0.8: a third
  /// of its pairs, nearly all of them confident doppelgangers).
  double first_tree_budget_trees = 4.0;
  /// Extra top-weight bridges added after the trees (verified, each on a
  /// community pair not used yet; within the redundancy budget).
  int num_top_bridges = 0;
  /// For every tree bridge with fewer than weak_link_max_inliers inliers, add
  /// up to this many verified backup bridges between the same two
  /// communities (within the redundancy budget).
  int num_backup_bridges = 1;
  /// Inlier count below which a tree bridge counts as a weak link.
  int weak_link_max_inliers = 50;
  /// Upper bound on pairs sent to the scorer at once; the builder asks for
  /// min(this, scorer's preferred batch size). Batching scores, ahead of
  /// time, the next bridges Kruskal would meet if all before them were
  /// rejected, as many as the rejections met since the last bridge taken
  /// (plus one): long runs of doppelgangers are verified in full batches,
  /// while a scene whose bridges mostly pass is verified lazily.
  int max_verify_batch_size = 256;
  /// When greedy packing leaves the trees' union less than K-edge-connected
  /// (greedy Kruskal can miss a packing that exists), add the heaviest
  /// verified bridges across each deficient minimum cut until every
  /// component of the community graph is K-edge-connected, no bridge
  /// across the cut passes verification, or the redundancy budget is spent.
  bool restore_connectivity = true;
  /// When the trees leave communities apart (every bridge between them
  /// scored below verify_threshold), join them through the best-scoring
  /// bridges already scored, if they score at least this: a component
  /// reconstructed through its most trustworthy bridge rather than two
  /// models. No bridge is scored for it. A value >= verify_threshold turns
  /// it off.
  double fallback_threshold = 0.5;
  /// A bridge that closes a cycle with edges already in the skeleton (every
  /// bridge after the first tree: later trees, backups, top-weight and
  /// connectivity bridges) is taken only if the relative rotations around
  /// the shortest such cycle compose to within this many degrees of the
  /// identity (loop consistency, Zach et al. CVPR 2010); the cycle runs over
  /// the communities' top-k edges and the bridges taken. A doppelganger of a
  /// symmetric object passes a two-view test but turns its loop by the
  /// symmetry. The cycle is checked before the bridge is scored, so a
  /// bridge it rejects costs no verifier call. Needs a scorer that reports
  /// rotations (BridgeScorer::CycleRotationErrorDeg); 0 turns the check
  /// off.
  double max_cycle_rotation_deg = 45.0;
  /// A bridge that closes no cycle with the skeleton (it joins two parts
  /// the skeleton holds apart, as every bridge of the first tree and of the
  /// fallback does) is also checked against the near misses met before it
  /// between the same two parts: bridges already scored and rejected with a
  /// score in [fallback_threshold, verify_threshold). Each near miss closes
  /// a cycle with the bridge; if the near misses whose cycle turns by more
  /// than max_cycle_rotation_deg outweigh (by view-graph weight, the
  /// trees' order) the bridge and the near misses whose cycle closes, the
  /// bridge is refused. The fallback
  /// votes the same way among its candidates, but where the vote refuses
  /// every candidate between two parts it still takes the best-scoring one
  /// (one model rather than pieces). No pair is scored for the vote. An
  /// addition to Algorithm 1 that acts only for tau above
  /// fallback_threshold (at the defaults, 0.5 and 0.5, there are no near
  /// misses and nothing changes): a score can rank a few weak doppelgangers
  /// above strong true bridges, which tau then rejects, and the first tree
  /// would join the parts through a doppelganger alone. Needs a scorer that
  /// reports rotations, and max_cycle_rotation_deg > 0.
  bool near_miss_vote = true;
  /// A bridge that joins two parts held apart (as for near_miss_vote), beyond
  /// the rank tiers (rank > rank_tiers) and scored below redundant_threshold,
  /// is also checked against up to this many of the heaviest other bridges
  /// between the same two parts that nothing has rejected (not yet scored, or
  /// scored and passed): they vote as near misses do, by weight, through the
  /// rotation of the cycle each closes with it. No pair is scored for it: the
  /// rotations are the pairs' stored two-view geometry. 0 turns it off; 8 was
  /// set before measuring and not tuned (docs/decisions.md, nineteenth
  /// session). An addition to Algorithm 1, whose first tree closes no cycle and
  /// so has no loop check: where two streets cross, a doppelganger between
  /// their facades can be the first bridge the tree meets between them while
  /// the true pairs at the crossing, which turn its cycle by the angle between
  /// the streets, outweigh it together. Bridges among the few strongest pairs
  /// of both their images, or scored confidently, are not put to the vote:
  /// around a block or a symmetric object the doppelgangers between two parts
  /// can outweigh the true pairs (docs/decisions.md, nineteenth session). With
  /// rank_tiers 0 no bridge is exempt for its rank (every bridge put to the
  /// vote was measured worse). Redundant bridges need redundant_threshold, so
  /// in effect only the first tree's and the fallback's meet their peers. A
  /// bridge refused by the vote that passed tau still joins parts nothing else
  /// joins, as the fallback's last resort (even when there is no fallback).
  /// Needs a scorer that reports rotations, and max_cycle_rotation_deg > 0.
  int peer_vote_size = 8;
  /// Trees meet bridges by neighbour rank before weight: a bridge's rank is
  /// the larger, over its two images, of its place among that image's
  /// verified pairs by weight (1 = the strongest). Bridges of rank r <=
  /// rank_tiers come in tier r, each tier in weight order, and all the
  /// others after them, in weight order; 0 keeps Algorithm 1's order by
  /// weight. A deviation from Algorithm 1 (which orders by weight alone):
  /// on a street an image has one or two true pairs among a hundred or more
  /// doppelgangers, so the true link between two neighbouring communities
  /// is among the strongest pairs of both its images, while a doppelganger
  /// can outweigh it and still be among neither image's strongest (the
  /// mutual k-nearest-neighbour graph, as the communities use for k = 1).
  /// Only the trees use this order; redundant bridges keep weight order.
  int rank_tiers = 4;
  /// Bridges whose rank (as for rank_tiers) exceeds this are not bridges
  /// the skeleton may take, in any role (not scored, not counted as
  /// rejected: Skeleton::num_rank_excluded); 0 takes every rank. A
  /// deviation from Algorithm 1, measured and rejected as a default: at 12
  /// it split crossing_streets_1000_s1 and crossing_streets_150_s1 (true
  /// bridges of rank 13 to 21 were their only links), at 16 it gained
  /// nothing (docs/decisions.md, fourteenth session).
  int max_bridge_rank = 0;

  /// Weigh the intra-community edges that join a community's skeletal
  /// images by the share of their inliers that agree with the pose the
  /// scorer accepts for them (BridgeScorer::ConsistentShare; each scored
  /// lazily, only if the community's maximum spanning tree could take it;
  /// the edges of the tree by view-graph weight, which it always asks
  /// about, in one batch first: BridgeScorer::ConsistentShares).
  /// An addition to the paper, which trusts these edges unverified: on a
  /// street a pair two to four images apart also matches the facade one
  /// period over, along its epipolar lines, and those matches let it outweigh
  /// the true links between; the pose the scorer accepts for such a pair
  /// keeps only one of the two halves. A scorer that cannot tell (plug-ins)
  /// leaves the weights as they are.
  bool intra_consistent_weights = true;

  void Check() const;
  /// The threshold a bridge of `role` must reach (`tree`: its tree index,
  /// for kTree).
  double ThresholdFor(BridgeRole role, int tree) const;
  /// K for a graph of `num_images` images.
  int NumTreesFor(size_t num_images) const;
};

/// A bridge that was scored, with its outcome.
struct BridgeRecord {
  ImagePair pair;
  CommunityId community1 = kInvalidCommunityId;
  CommunityId community2 = kInvalidCommunityId;
  uint32_t weight = 0;
  /// The larger of its places among its two images' pairs by weight
  /// (1 = the strongest); 0 if neither rank_tiers nor max_bridge_rank
  /// asked for ranks.
  uint32_t rank = 0;
  /// The scorer's score; negative if the bridge was rejected by its cycle
  /// (SkeletonOptions::max_cycle_rotation_deg) before being scored.
  double score = 1.0;
  bool accepted = false;
  BridgeRole role = BridgeRole::kTree;
  /// Tree index (0-based) for kTree bridges, -1 otherwise.
  int tree = -1;
  /// Rotation error (degrees) of the cycle the bridge closed with the
  /// skeleton when it was considered; negative if it closed none or the
  /// scorer could not tell.
  double cycle_error_deg = -1.0;
  /// Refused by the near misses or peers between the parts it joins
  /// (SkeletonOptions::near_miss_vote, peer_vote_size) though its score
  /// passed; its cycle_error_deg is then the largest of the cycles it closed
  /// with them.
  bool outvoted = false;
};

/// The skeletal subgraph G_s = (V_s, E_s).
struct Skeleton {
  int num_trees = 0;
  /// Bridges taken into the skeleton, in the order they were taken.
  std::vector<BridgeRecord> bridges;
  /// Bridges the verifier rejected (each once).
  std::vector<BridgeRecord> rejected;
  /// Intra-community edges joining the skeletal images of each community.
  std::vector<ViewGraphEdge> intra_edges;
  /// V_s, sorted.
  std::vector<ImageId> images;
  /// Number of candidate bridges (verified pairs across communities).
  size_t num_candidate_bridges = 0;
  /// Candidate bridges left out by SkeletonOptions::max_bridge_rank.
  size_t num_rank_excluded = 0;
  /// Bridges the near-miss or peer vote refused (SkeletonOptions::
  /// near_miss_vote, peer_vote_size), in the trees (in `rejected`, marked
  /// `outvoted`) or in the fallback (near misses themselves, in `rejected`
  /// for their score).
  size_t num_outvoted = 0;
  /// Number of pairs scored by the verifier (each at most once).
  size_t num_verified = 0;
  /// Of those, the pairs the first tree scored
  /// (SkeletonOptions::first_tree_budget_trees).
  size_t num_verified_first_tree = 0;
  /// Number of calls into the scorer (batches).
  size_t num_scorer_calls = 0;

  /// E_s: bridges and intra-community edges, as pairs.
  std::vector<ImagePair> Edges() const;
  bool Contains(ImageId id) const;
};

/// Builds the skeleton. `scorer` may be null (every bridge accepted, and
/// intra-community edges weighed by the view graph alone); otherwise it also
/// weighs the intra-community edges (SkeletonOptions::intra_consistent_weights).
Skeleton BuildSkeleton(const ViewGraph& graph, const Communities& communities,
                       BridgeScorer* scorer, const SkeletonOptions& options);

}  // namespace hisfm
