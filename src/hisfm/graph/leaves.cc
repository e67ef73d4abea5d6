#include "hisfm/graph/leaves.h"

#include <algorithm>

#include "hisfm/util/error.h"

namespace hisfm {

void LeafOptions::Check() const {
  HISFM_CHECK_OPTION(leaf_edges, leaf_edges >= 1, ">= 1");
  HISFM_CHECK_OPTION(leaf_leaf_edges, leaf_leaf_edges >= 0, ">= 0");
}

std::vector<ViewGraphEdge> AttachLeaves(const ViewGraph& graph,
                                        const Communities& communities,
                                        const Skeleton& skeleton,
                                        const LeafOptions& options) {
  options.Check();
  std::vector<ViewGraphEdge> out;
  const auto& edges = graph.Edges();
  if (options.keep_top_k_edges) {
    for (const ViewGraphEdge& e : communities.top_k_edges) {
      if (!skeleton.Contains(e.pair.image_id1) ||
          !skeleton.Contains(e.pair.image_id2)) {
        out.push_back(e);
      }
    }
  }
  std::vector<size_t> to_skeleton;
  std::vector<size_t> to_leaves;
  for (size_t i = 0; i < graph.NumImages(); ++i) {
    const ImageId id = graph.Images()[i];
    if (skeleton.Contains(id) || graph.IncidentEdges(i).empty()) continue;
    const CommunityId c = communities.Of(id);
    to_skeleton.clear();
    to_leaves.clear();
    for (size_t e : graph.IncidentEdges(i)) {
      const ImageId other = graph.OtherEnd(e, id);
      if (communities.Of(other) != c) continue;
      (skeleton.Contains(other) ? to_skeleton : to_leaves).push_back(e);
    }
    auto by_weight = [&](size_t a, size_t b) {
      return edges[a].weight > edges[b].weight ||
             (edges[a].weight == edges[b].weight && a < b);
    };
    std::sort(to_skeleton.begin(), to_skeleton.end(), by_weight);
    std::sort(to_leaves.begin(), to_leaves.end(), by_weight);
    // Skeletal neighbours first; fill up with leaves if there are too few.
    size_t num_leaf_edges = options.leaf_leaf_edges;
    const size_t num_skeleton_edges =
        std::min<size_t>(options.leaf_edges, to_skeleton.size());
    num_leaf_edges += options.leaf_edges - num_skeleton_edges;
    for (size_t k = 0; k < num_skeleton_edges; ++k) {
      out.push_back(edges[to_skeleton[k]]);
    }
    for (size_t k = 0; k < std::min(num_leaf_edges, to_leaves.size()); ++k) {
      out.push_back(edges[to_leaves[k]]);
    }
  }
  std::sort(out.begin(), out.end(),
            [](const ViewGraphEdge& a, const ViewGraphEdge& b) {
              return a.pair < b.pair;
            });
  out.erase(std::unique(out.begin(), out.end(),
                        [](const ViewGraphEdge& a, const ViewGraphEdge& b) {
                          return a.pair == b.pair;
                        }),
            out.end());
  return out;
}

}  // namespace hisfm
