#include "hisfm/verify/view_graph_reader.h"

#include <utility>
#include <vector>

namespace hisfm {

ViewGraph ReadViewGraph(const Database& database, uint32_t min_num_matches) {
  std::vector<ImageId> images;
  for (const DatabaseImage& im : database.ReadImages()) {
    images.push_back(im.image_id);
  }
  std::vector<ViewGraphEdge> edges;
  for (const VerifiedPair& p : database.ReadVerifiedPairs(min_num_matches)) {
    edges.push_back({p.pair, p.num_inliers});
  }
  return ViewGraph::FromEdges(std::move(images), edges);
}

}  // namespace hisfm
