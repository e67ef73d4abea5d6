// Local community partitioning by top-k filtering.
//
// HiSfM paper (Zhao, Cui, Tao, Shen, "HiSfM: Disambiguating Structure-from-
// Motion via Scaffold-Anchored Hierarchical Reconstruction"), Sec. III-A: keep
// each image's k strongest neighbours by inlier count; the connected
// components of that sparse graph are the communities.
#pragma once

#include <unordered_map>
#include <vector>

#include "hisfm/graph/view_graph.h"

namespace hisfm {

struct CommunityOptions {
  /// Number of strongest neighbours each image keeps (k; the paper uses 1).
  int top_k = 1;

  /// Throws hisfm::Error if an option is out of range.
  void Check() const;
};

/// A partition of the images into communities.
struct Communities {
  /// Members of each community, sorted by image id; communities are ordered
  /// by their smallest image id.
  std::vector<std::vector<ImageId>> members;
  /// Community of each image.
  std::unordered_map<ImageId, CommunityId> community_of;
  /// The top-k edges that formed the communities (sorted, unique).
  std::vector<ViewGraphEdge> top_k_edges;

  size_t NumCommunities() const { return members.size(); }
  CommunityId Of(ImageId id) const { return community_of.at(id); }
};

/// Partitions the view graph into top-k communities. Ties in weight are
/// broken by the smaller neighbour id, so the result is deterministic.
Communities ComputeCommunities(const ViewGraph& graph,
                               const CommunityOptions& options);

}  // namespace hisfm
