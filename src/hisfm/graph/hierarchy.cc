#include "hisfm/graph/hierarchy.h"

#include <algorithm>
#include <map>

#include "hisfm/graph/union_find.h"

namespace hisfm {

void HierarchyOptions::Check() const {
  communities.Check();
  skeleton.Check();
  leaves.Check();
}

std::vector<ImagePair> Hierarchy::Edges() const {
  std::vector<ImagePair> out = skeleton.Edges();
  for (const ViewGraphEdge& e : leaf_edges) out.push_back(e.pair);
  for (const ViewGraphEdge& e : support_edges) out.push_back(e.pair);
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

Hierarchy BuildHierarchy(const ViewGraph& graph, BridgeScorer* scorer,
                         const HierarchyOptions& options) {
  return BuildHierarchy(
      graph,
      [scorer](const Communities&) -> std::unique_ptr<BridgeScorer> {
        if (!scorer) return nullptr;
        return std::make_unique<BorrowedScorer>(scorer);
      },
      options);
}

Hierarchy BuildHierarchy(const ViewGraph& graph,
                         const ScorerFactory& make_scorer,
                         const HierarchyOptions& options) {
  options.Check();
  Hierarchy h;
  h.communities = ComputeCommunities(graph, options.communities);
  std::unique_ptr<BridgeScorer> scorer =
      make_scorer ? make_scorer(h.communities) : nullptr;
  h.skeleton =
      BuildSkeleton(graph, h.communities, scorer.get(), options.skeleton);
  h.leaf_edges =
      AttachLeaves(graph, h.communities, h.skeleton, options.leaves);

  const std::vector<ImagePair> edges = h.Edges();
  const std::vector<ImagePair> skeleton_edges = h.skeleton.Edges();
  UnionFind uf(graph.NumImages());
  for (const ImagePair& p : edges) {
    uf.Union(graph.IndexOf(p.image_id1), graph.IndexOf(p.image_id2));
  }
  std::map<size_t, HierarchyComponent> by_root;
  for (size_t i = 0; i < graph.NumImages(); ++i) {
    const ImageId id = graph.Images()[i];
    if (graph.IncidentEdges(i).empty()) {
      h.isolated_images.push_back(id);
      continue;
    }
    HierarchyComponent& c = by_root[uf.Find(i)];
    c.images.push_back(id);
    if (h.skeleton.Contains(id)) c.skeleton_images.push_back(id);
  }
  for (const ImagePair& p : edges) {
    by_root[uf.Find(graph.IndexOf(p.image_id1))].edges.push_back(p);
  }
  for (const ImagePair& p : skeleton_edges) {
    by_root[uf.Find(graph.IndexOf(p.image_id1))].skeleton_edges.push_back(p);
  }
  for (auto& [root, c] : by_root) {
    if (c.images.size() >= 2) h.components.push_back(std::move(c));
  }
  std::stable_sort(h.components.begin(), h.components.end(),
                   [](const HierarchyComponent& a, const HierarchyComponent& b) {
                     return a.images.size() > b.images.size();
                   });
  return h;
}

}  // namespace hisfm
