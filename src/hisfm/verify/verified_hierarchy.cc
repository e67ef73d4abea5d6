#include "hisfm/verify/verified_hierarchy.h"

#include <algorithm>
#include <set>

#include "hisfm/util/error.h"
#include "hisfm/util/logging.h"

namespace hisfm {

void VerifiedHierarchyOptions::Check() const {
  HISFM_CHECK_OPTION(max_rounds >= 1);
  HISFM_CHECK_OPTION(trusted_threshold >= 0 && trusted_threshold <= 1);
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

VerifiedHierarchy BuildVerifiedHierarchy(
    const ViewGraph& graph, MultiViewVerifier& verifier,
    const HierarchyOptions& hierarchy_options,
    const VerifiedHierarchyOptions& options) {
  options.Check();
  VerifiedHierarchy out;
  out.graph = graph;
  std::set<ImagePair> removed;
  for (int round = 0; round < options.max_rounds; ++round) {
    out.rounds = round + 1;
    out.hierarchy = BuildHierarchy(out.graph, &verifier, hierarchy_options);
    std::vector<RejectedTrustedEdge> failing;
    for (const ImagePair& pair : TrustedEdges(out.hierarchy)) {
      const double score = verifier.Score({pair}).front();
      if (score < options.trusted_threshold) {
        failing.push_back({pair, out.graph.Weight(pair.image_id1,
                                                  pair.image_id2),
                           score, round});
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
    HISFM_LOG_DEBUG("verified hierarchy: round {} rejected {} trusted edges",
                    round, failing.size());
  }
  if (options.clean_inliers) {
    for (const ImagePair& pair : out.hierarchy.Edges()) {
      std::vector<FeatureMatch> inliers = verifier.ConsistentInliers(pair);
      out.num_inliers_before +=
          verifier.cache().Pair(pair.image_id1, pair.image_id2)->matches.size();
      out.num_inliers_after += inliers.size();
      out.inliers.emplace(pair, std::move(inliers));
    }
  }
  return out;
}

}  // namespace hisfm
