#include "hisfm/graph/trusted_edges.h"

#include <memory>
#include <set>

#include "hisfm/util/error.h"
#include "hisfm/util/logging.h"

namespace hisfm {

void TrustedEdgeOptions::Check() const {
  HISFM_CHECK_OPTION(threshold, threshold >= 0 && threshold <= 1,
                     "in [0, 1]");
  HISFM_CHECK_OPTION(max_rounds, max_rounds >= 1, ">= 1");
}

std::vector<ImagePair> TrustedEdges(const Hierarchy& hierarchy) {
  std::set<ImagePair> edges;
  for (const ViewGraphEdge& e : hierarchy.communities.top_k_edges) {
    edges.insert(e.pair);
  }
  for (const ViewGraphEdge& e : hierarchy.skeleton.intra_edges) {
    edges.insert(e.pair);
  }
  for (const ViewGraphEdge& e : hierarchy.leaf_edges) edges.insert(e.pair);
  return {edges.begin(), edges.end()};
}

JudgedHierarchy BuildHierarchyJudgingTrustedEdges(
    const ViewGraph& graph, const ScorerFactory& make_scorer,
    const HierarchyOptions& hierarchy_options,
    const TrustedEdgeOptions& options, const ScoreSpeaks& speaks) {
  options.Check();
  JudgedHierarchy out;
  out.graph = graph;
  PairScores& scores = out.scores;
  std::set<ImagePair> removed;
  std::set<ImagePair> judged;
  for (int round = 0; round < options.max_rounds; ++round) {
    out.rounds = round + 1;
    // The round's scorer judges the bridges while the hierarchy is built,
    // then its trusted edges.
    std::shared_ptr<BridgeScorer> scorer;
    out.hierarchy = BuildHierarchy(
        out.graph,
        [&](const Communities& communities) -> std::unique_ptr<BridgeScorer> {
          std::unique_ptr<BridgeScorer> made =
              make_scorer ? make_scorer(communities) : nullptr;
          if (!made) return nullptr;
          scorer = std::move(made);
          return std::make_unique<MemoScorer>(scorer, &scores);
        },
        hierarchy_options);
    if (!scorer || scorer->IsFree()) break;
    MemoScorer remembering(scorer, &scores);
    const std::vector<ImagePair> trusted = TrustedEdges(out.hierarchy);
    const std::vector<double> trusted_scores = remembering.Score(trusted);
    judged.insert(trusted.begin(), trusted.end());
    std::vector<RejectedTrustedEdge> failing;
    for (size_t i = 0; i < trusted.size(); ++i) {
      const ImagePair& pair = trusted[i];
      if (trusted_scores[i] < options.threshold && (!speaks || speaks(pair))) {
        failing.push_back({pair,
                           out.graph.Weight(pair.image_id1, pair.image_id2),
                           trusted_scores[i], round});
      }
    }
    out.num_unresolved = failing.size();
    if (failing.empty() || round + 1 == options.max_rounds) break;
    for (const RejectedTrustedEdge& r : failing) removed.insert(r.pair);
    out.rejected.insert(out.rejected.end(), failing.begin(), failing.end());
    std::vector<ViewGraphEdge> kept;
    for (const ViewGraphEdge& e : out.graph.Edges()) {
      if (!removed.count(e.pair)) kept.push_back(e);
    }
    out.graph = ViewGraph::FromEdges(graph.Images(), kept);
    HISFM_LOG_DEBUG("trusted edges: round {} rejected {} of {}", round,
                    failing.size(), trusted.size());
  }
  out.num_scored = judged.size();
  return out;
}

}  // namespace hisfm
