// Judging the edges the paper trusts.
//
// HiSfM (Sec. III-A to III-C) verifies only the bridges between communities
// and trusts the rest of its hierarchy: the top-k edges that form the
// communities, the skeleton's intra-community edges and the leaf edges. In a
// street of identical facades an image's strongest pair can be a
// doppelganger; a community joined through one spans two places, and its
// spanning tree and leaf edges must then cross between them, which folds the
// model as surely as a false bridge. Here the hierarchy is built, its trusted
// edges are scored by the same scorer as the bridges, the ones it rejects are
// removed from the graph and the hierarchy is rebuilt, until no trusted edge
// is rejected (each pair is scored once over all rounds).
#pragma once

#include <functional>
#include <vector>

#include "hisfm/graph/bridge_scorer.h"
#include "hisfm/graph/hierarchy.h"
#include "hisfm/graph/view_graph.h"

namespace hisfm {

struct TrustedEdgeOptions {
  /// A trusted edge scoring below this is rejected. Trusted edges are each
  /// image's strongest pairs, true far more often than the bridges Kruskal
  /// meets, so the default asks for stronger evidence to reject one than the
  /// bridges' threshold (SkeletonOptions::verify_threshold) asks to accept
  /// a bridge.
  double threshold = 0.25;
  /// Rebuilds at most this many times; trusted edges still rejected after
  /// the last round are kept and counted in JudgedHierarchy::num_unresolved.
  int max_rounds = 50;

  /// Throws hisfm::Error if an option is out of range.
  void Check() const;
};

/// A trusted edge the scorer rejected.
struct RejectedTrustedEdge {
  ImagePair pair;
  uint32_t weight = 0;
  double score = 0;
  /// Build round in which it was rejected (0-based).
  int round = 0;
};

/// A hierarchy whose trusted edges were judged.
struct JudgedHierarchy {
  Hierarchy hierarchy;
  /// The graph the final hierarchy was built on (rejected edges removed).
  ViewGraph graph;
  std::vector<RejectedTrustedEdge> rejected;
  /// Build rounds.
  int rounds = 0;
  /// Trusted edges below the threshold kept after the last round (not
  /// counting those whose score does not speak: ScoreSpeaks).
  size_t num_unresolved = 0;
  /// Trusted edges scored over all rounds (distinct pairs).
  size_t num_scored = 0;
  /// Every pair the scorer was asked about over all rounds, bridges and
  /// trusted edges (each asked once), with its score, for later stages to
  /// ask through a MemoScorer.
  PairScores scores;
};

/// The edges of `hierarchy` that the paper trusts without verification:
/// the communities' top-k edges, the skeleton's intra-community edges and
/// the leaf edges (sorted, unique).
std::vector<ImagePair> TrustedEdges(const Hierarchy& hierarchy);

/// Whether the scorer's score of a pair is evidence at all (a pair it could
/// not judge keeps the trust the paper gives it). Null: every score is.
using ScoreSpeaks = std::function<bool(const ImagePair&)>;

/// Builds the hierarchy of `graph` (bridges scored by the scorer
/// `make_scorer` creates, as in BuildHierarchy), then judges its trusted
/// edges with the same scorer and rebuilds without the rejected ones (see
/// the file comment). A free scorer (BridgeScorer::IsFree) or a null one
/// judges nothing: one round.
JudgedHierarchy BuildHierarchyJudgingTrustedEdges(
    const ViewGraph& graph, const ScorerFactory& make_scorer,
    const HierarchyOptions& hierarchy_options,
    const TrustedEdgeOptions& options, const ScoreSpeaks& speaks = nullptr);

}  // namespace hisfm
