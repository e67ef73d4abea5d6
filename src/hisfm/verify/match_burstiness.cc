#include "hisfm/verify/match_burstiness.h"

#include <algorithm>
#include <cmath>

namespace hisfm {

KeypointDegrees ComputeKeypointDegrees(const Database& database,
                                       const ViewGraph& graph) {
  std::unordered_map<ImageId, size_t> num_keypoints =
      database.ReadNumKeypoints();
  KeypointDegrees degree;
  for (const ImageId id : graph.Images()) {
    degree[id].assign(num_keypoints[id], 0);
  }
  const std::vector<ImagePair> pairs = graph.Pairs();
  const auto bump = [](std::vector<uint16_t>& d, Point2DIdx k) {
    if (k < d.size() && d[k] < UINT16_MAX) ++d[k];
  };
  database.ForEachInlierMatches(
      pairs, [&](const ImagePair& pair, FeatureMatchSpan matches) {
        std::vector<uint16_t>& d1 = degree[pair.image_id1];
        std::vector<uint16_t>& d2 = degree[pair.image_id2];
        for (const FeatureMatch& m : matches) {
          bump(d1, m.idx1);
          bump(d2, m.idx2);
        }
      });
  return degree;
}

std::unordered_map<ImagePair, double, ImagePairHash> BurstinessWeights(
    const Database& database, const ViewGraph& graph,
    const KeypointDegrees& degree) {
  const std::vector<ImagePair> pairs = graph.Pairs();
  const std::vector<uint16_t> none;
  const auto of = [&](ImageId id) -> const std::vector<uint16_t>& {
    auto it = degree.find(id);
    return it == degree.end() ? none : it->second;
  };
  std::unordered_map<ImagePair, double, ImagePairHash> weights;
  weights.reserve(pairs.size());
  database.ForEachInlierMatches(
      pairs, [&](const ImagePair& pair, FeatureMatchSpan matches) {
        const std::vector<uint16_t>& d1 = of(pair.image_id1);
        const std::vector<uint16_t>& d2 = of(pair.image_id2);
        double w = 0;
        for (const FeatureMatch& m : matches) {
          if (m.idx1 >= d1.size() || m.idx2 >= d2.size()) continue;
          w += 1.0 / std::sqrt(static_cast<double>(std::max<uint16_t>(
                                   1, d1[m.idx1])) *
                               std::max<uint16_t>(1, d2[m.idx2]));
        }
        weights[pair] = w;
      });
  return weights;
}

ViewGraph ReweightedGraph(
    const ViewGraph& graph,
    const std::unordered_map<ImagePair, double, ImagePairHash>& weights,
    double scale) {
  std::vector<ViewGraphEdge> edges = graph.Edges();
  for (ViewGraphEdge& e : edges) {
    auto it = weights.find(e.pair);
    const double w = it == weights.end() ? 0.0 : it->second;
    e.weight = static_cast<uint32_t>(
        std::max(1.0, std::min(4.0e9, std::round(scale * w))));
  }
  return ViewGraph::FromEdges(graph.Images(), edges);
}

}  // namespace hisfm
