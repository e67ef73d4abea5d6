// The HiSfM hierarchy with every edge it uses verified by the builtin
// multi-view verifier.
//
// The paper verifies only the inter-community bridges and trusts the
// strongest pairs (Sec. III-A to III-C). Here the hierarchy is built with
// its trusted edges judged too (graph/trusted_edges.h), then support edges
// are added, and the verifier reports which inliers of each used edge agree
// with the geometry it accepted: the reconstruction uses only those.
#pragma once

#include <set>
#include <unordered_map>
#include <vector>

#include "hisfm/graph/hierarchy.h"
#include "hisfm/graph/trusted_edges.h"
#include "hisfm/graph/view_graph.h"
#include "hisfm/verify/multiview_verifier.h"

namespace hisfm {

struct VerifiedHierarchyOptions {
  /// How the trusted edges are judged (graph/trusted_edges.h); with this
  /// verifier only a pair its edge test judged (PairFeatures::Speaks) can be
  /// rejected.
  TrustedEdgeOptions trusted_edges;
  /// Replace each used edge's inliers by those consistent with the geometry
  /// its test accepted (within EdgeTestOptions::inlier_error_factor times
  /// the pose's support error).
  bool clean_inliers = true;
  /// A trusted edge whose mutual rank (MutualRanks in graph/view_graph.h,
  /// computed once on the graph given to BuildVerifiedHierarchy, before
  /// any rejection) is at most this is kept whatever its score, as a pair
  /// the edge test could not judge is: it is among the few strongest pairs
  /// of both its images. The test predicts the points one image's ego
  /// model holds in the other image; on a street of identical facades an
  /// ego model that took in a doppelganger neighbour predicts points a
  /// true pair cannot match, and the test then rejects true neighbours. On
  /// crossing_streets_1000_s3 (tuning half) the test rejected 169 trusted
  /// edges, 105 of them with the true geometry; of those of mutual rank 4
  /// or less by inlier count, 34 had the true geometry and 2 did not
  /// (docs/decisions.md, eighteenth session; the graph given here ranks by
  /// burstiness weights by default). 0 judges every trusted edge.
  int trusted_keep_rank = 4;
  /// Each image's this many strongest pairs (in the graph the hierarchy is
  /// built on) that score at least support_threshold join the edges its
  /// component is reconstructed from (Hierarchy::support_edges; between two
  /// skeletal images, the scaffold's too). The paper's hierarchy keeps about
  /// two edges per image; incremental SfM on weakly textured or planar
  /// scenes needs more to register every image. 0 adds none.
  int support_edges = 3;
  /// Minimum score of a support edge. A support edge adds constraints the
  /// paper's hierarchy does not have, so it must pass the bridges' test
  /// (the paper's tau), not the weaker trusted-edge one.
  double support_threshold = 0.8;

  /// Throws hisfm::Error if an option is out of range.
  void Check() const;
};

/// The judged hierarchy (hierarchy, graph, rejected trusted edges, rounds)
/// and what the builtin verifier adds to it.
struct VerifiedHierarchy : JudgedHierarchy {
  /// Each image's strongest pairs (up to support_edges) inside its
  /// component that score at least the bridges' threshold
  /// (SkeletonOptions::verify_threshold) but below support_threshold: not
  /// part of the hierarchy; the reconstruction uses them only to register
  /// images that the hierarchy's edges leave unregistered.
  std::vector<ViewGraphEdge> reserve_edges;
  /// Inliers to use per edge of the hierarchy and per reserve edge
  /// (oriented as stored), when clean_inliers.
  std::unordered_map<ImagePair, std::vector<FeatureMatch>, ImagePairHash>
      inliers;
  /// Inliers before and after cleaning, over the hierarchy's and the
  /// reserve edges.
  size_t num_inliers_before = 0;
  size_t num_inliers_after = 0;
  /// Pairs the hierarchy asked about that were answered as pre-verified
  /// (BuildVerifiedHierarchy's `pre_verified`), without the verifier.
  size_t num_pre_verified = 0;
};

/// Adds to `hierarchy` each image's `count` strongest pairs of `graph` that
/// `verifier` scores at least `threshold`, inside components only (see
/// VerifiedHierarchyOptions::support_edges). If `reserve` is given, the
/// pairs among them scoring at least `reserve_threshold` but below
/// `threshold` are appended to it instead (VerifiedHierarchy::reserve_edges).
/// Returns how many distinct pairs `verifier` was asked to score.
size_t AddSupportEdges(const ViewGraph& graph, BridgeScorer& verifier,
                     int count, double threshold, Hierarchy* hierarchy,
                     std::vector<ViewGraphEdge>* reserve = nullptr,
                     double reserve_threshold = 1.0);

/// The inliers of each pair of `pairs` that agree with the geometry the
/// builtin edge test accepts for it (MultiViewVerifier::ConsistentInliers),
/// by pair, in `inliers`; adds the counts before and after to `before` and
/// `after`. A pair the test cannot judge keeps all its inliers, and the
/// pairs of `skip` (if given; pre-verified ones) are left out.
void CleanInliers(const std::vector<ImagePair>& pairs,
                  MultiViewVerifier& verifier,
                  std::unordered_map<ImagePair, std::vector<FeatureMatch>,
                                     ImagePairHash>* inliers,
                  size_t* before, size_t* after,
                  const std::set<ImagePair>* skip = nullptr);

/// Builds the hierarchy of `graph` with `verifier` scoring bridges (against
/// the skeleton's verify_threshold) and trusted edges (against
/// trusted_edges.threshold, except those trusted_keep_rank keeps; see the
/// file comment). The pairs of `pre_verified` (if given; pairs a stronger
/// test accepted, PreVerifiedScorer) are not asked of `verifier`: they
/// score 1, are not rejected by a score (the skeleton's cycle check still
/// applies to bridges) and keep their inliers uncleaned.
VerifiedHierarchy BuildVerifiedHierarchy(
    const ViewGraph& graph, MultiViewVerifier& verifier,
    const HierarchyOptions& hierarchy_options,
    const VerifiedHierarchyOptions& options,
    const std::set<ImagePair>* pre_verified = nullptr);

}  // namespace hisfm
