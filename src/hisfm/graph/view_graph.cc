#include "hisfm/graph/view_graph.h"

#include <algorithm>

namespace hisfm {

std::vector<ImagePair> ViewGraph::Pairs() const {
  std::vector<ImagePair> out;
  out.reserve(edges_.size());
  for (const ViewGraphEdge& e : edges_) out.push_back(e.pair);
  return out;
}

ViewGraph ViewGraph::FromEdges(std::vector<ImageId> images,
                               const std::vector<ViewGraphEdge>& edges) {
  ViewGraph g;
  std::sort(images.begin(), images.end());
  images.erase(std::unique(images.begin(), images.end()), images.end());
  g.images_ = std::move(images);
  g.index_.reserve(g.images_.size());
  for (size_t i = 0; i < g.images_.size(); ++i) g.index_[g.images_[i]] = i;
  g.edges_.reserve(edges.size());
  for (const ViewGraphEdge& e : edges) {
    if (e.pair.image_id1 == e.pair.image_id2) continue;
    if (!g.HasImage(e.pair.image_id1) || !g.HasImage(e.pair.image_id2))
      continue;
    g.edges_.push_back({ImagePair(e.pair.image_id1, e.pair.image_id2),
                        e.weight});
  }
  std::sort(g.edges_.begin(), g.edges_.end(),
            [](const ViewGraphEdge& a, const ViewGraphEdge& b) {
              return a.pair < b.pair || (a.pair == b.pair && a.weight > b.weight);
            });
  g.edges_.erase(std::unique(g.edges_.begin(), g.edges_.end(),
                             [](const ViewGraphEdge& a, const ViewGraphEdge& b) {
                               return a.pair == b.pair;
                             }),
                 g.edges_.end());
  g.BuildAdjacency();
  return g;
}

void ViewGraph::BuildAdjacency() {
  adjacency_.assign(images_.size(), {});
  std::vector<size_t> degree(images_.size(), 0);
  for (const ViewGraphEdge& e : edges_) {
    ++degree[index_[e.pair.image_id1]];
    ++degree[index_[e.pair.image_id2]];
  }
  for (size_t i = 0; i < images_.size(); ++i) adjacency_[i].reserve(degree[i]);
  for (size_t k = 0; k < edges_.size(); ++k) {
    adjacency_[index_[edges_[k].pair.image_id1]].push_back(k);
    adjacency_[index_[edges_[k].pair.image_id2]].push_back(k);
  }
}

uint32_t ViewGraph::Weight(ImageId a, ImageId b) const {
  auto it = index_.find(a);
  if (it == index_.end() || !HasImage(b)) return 0;
  for (size_t e : adjacency_[it->second]) {
    if (OtherEnd(e, a) == b) return edges_[e].weight;
  }
  return 0;
}

std::vector<size_t> StrongestEdges(const ViewGraph& graph, size_t index,
                                   size_t count) {
  std::vector<size_t> edges = graph.IncidentEdges(index);
  const ImageId image_id = graph.Images()[index];
  const auto stronger = [&](size_t a, size_t b) {
    const uint32_t wa = graph.Edges()[a].weight;
    const uint32_t wb = graph.Edges()[b].weight;
    if (wa != wb) return wa > wb;
    return graph.OtherEnd(a, image_id) < graph.OtherEnd(b, image_id);
  };
  const size_t k = std::min(count, edges.size());
  std::partial_sort(edges.begin(), edges.begin() + k, edges.end(), stronger);
  edges.resize(k);
  return edges;
}

std::vector<ImageId> StrongestNeighbours(const ViewGraph& graph,
                                         ImageId image_id, size_t count,
                                         ImageId exclude) {
  std::vector<ImageId> out;
  if (!graph.HasImage(image_id)) return out;
  const size_t index = graph.IndexOf(image_id);
  const bool excluding = exclude != kInvalidImageId && graph.Weight(image_id, exclude) > 0;
  for (const size_t e : StrongestEdges(graph, index, count + (excluding ? 1 : 0))) {
    const ImageId other = graph.OtherEnd(e, image_id);
    if (other != exclude && out.size() < count) out.push_back(other);
  }
  return out;
}

std::vector<uint32_t> MutualRanks(const ViewGraph& graph) {
  std::vector<uint32_t> ranks(graph.NumEdges(), 0);
  for (size_t i = 0; i < graph.NumImages(); ++i) {
    const std::vector<size_t> edges =
        StrongestEdges(graph, i, graph.IncidentEdges(i).size());
    for (size_t r = 0; r < edges.size(); ++r) {
      ranks[edges[r]] =
          std::max(ranks[edges[r]], static_cast<uint32_t>(r + 1));
    }
  }
  return ranks;
}

std::set<ImagePair> PairsOfMutualRankAtMost(const ViewGraph& graph,
                                            uint32_t max_rank) {
  std::set<ImagePair> pairs;
  if (max_rank == 0) return pairs;
  const std::vector<uint32_t> ranks = MutualRanks(graph);
  for (size_t e = 0; e < ranks.size(); ++e) {
    if (ranks[e] <= max_rank) pairs.insert(graph.Edges()[e].pair);
  }
  return pairs;
}

}  // namespace hisfm
