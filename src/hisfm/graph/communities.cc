#include "hisfm/graph/communities.h"

#include <algorithm>
#include <map>

#include "hisfm/graph/union_find.h"
#include "hisfm/util/error.h"

namespace hisfm {

void CommunityOptions::Check() const {
  HISFM_CHECK_OPTION(top_k, top_k >= 1, ">= 1");
}

Communities ComputeCommunities(const ViewGraph& graph,
                               const CommunityOptions& options) {
  options.Check();
  const std::vector<ImageId>& images = graph.Images();
  const std::vector<ViewGraphEdge>& edges = graph.Edges();
  UnionFind uf(images.size());
  std::vector<size_t> kept;
  std::vector<size_t> incident;
  for (size_t i = 0; i < images.size(); ++i) {
    incident = graph.IncidentEdges(i);
    const ImageId id = images[i];
    const size_t k = std::min<size_t>(options.top_k, incident.size());
    std::partial_sort(incident.begin(), incident.begin() + k, incident.end(),
                      [&](size_t a, size_t b) {
                        if (edges[a].weight != edges[b].weight)
                          return edges[a].weight > edges[b].weight;
                        return graph.OtherEnd(a, id) < graph.OtherEnd(b, id);
                      });
    for (size_t t = 0; t < k; ++t) {
      const ImagePair& p = edges[incident[t]].pair;
      uf.Union(graph.IndexOf(p.image_id1), graph.IndexOf(p.image_id2));
      kept.push_back(incident[t]);
    }
  }
  std::sort(kept.begin(), kept.end());
  kept.erase(std::unique(kept.begin(), kept.end()), kept.end());

  Communities out;
  std::map<size_t, CommunityId> root_to_community;
  // Images are in ascending id order, so communities are numbered by their
  // smallest member.
  for (size_t i = 0; i < images.size(); ++i) {
    const size_t root = uf.Find(i);
    auto it = root_to_community.find(root);
    if (it == root_to_community.end()) {
      it = root_to_community
               .emplace(root, static_cast<CommunityId>(out.members.size()))
               .first;
      out.members.emplace_back();
    }
    out.members[it->second].push_back(images[i]);
    out.community_of[images[i]] = it->second;
  }
  out.top_k_edges.reserve(kept.size());
  for (size_t e : kept) out.top_k_edges.push_back(edges[e]);
  return out;
}

}  // namespace hisfm
