// The view graph: images as vertices, verified pairs as edges weighted by
// their number of inlier matches (w_ij in the HiSfM paper, Sec. III-A).
#pragma once

#include <cstdint>
#include <set>
#include <unordered_map>
#include <vector>

#include "hisfm/util/types.h"

namespace hisfm {

/// One verified pair with its weight (number of inliers).
struct ViewGraphEdge {
  ImagePair pair;
  uint32_t weight = 0;
};

/// Undirected weighted graph over images. Images are stored in ascending id
/// order and addressed by a dense index for fast adjacency.
class ViewGraph {
 public:
  ViewGraph() = default;
  /// Builds a graph from explicit images and edges (duplicates are merged,
  /// keeping the largest weight; edges to unknown images are ignored).
  static ViewGraph FromEdges(std::vector<ImageId> images,
                             const std::vector<ViewGraphEdge>& edges);

  size_t NumImages() const { return images_.size(); }
  size_t NumEdges() const { return edges_.size(); }
  /// Image ids in ascending order.
  const std::vector<ImageId>& Images() const { return images_; }
  /// All edges, sorted by pair.
  const std::vector<ViewGraphEdge>& Edges() const { return edges_; }
  bool HasImage(ImageId id) const { return index_.count(id) > 0; }
  /// Dense index of an image in Images().
  size_t IndexOf(ImageId id) const { return index_.at(id); }
  /// Edge indices incident to the image with dense index `i`.
  const std::vector<size_t>& IncidentEdges(size_t i) const {
    return adjacency_[i];
  }
  /// The other end of edge `e` seen from image `id`.
  ImageId OtherEnd(size_t e, ImageId id) const {
    const ImagePair& p = edges_[e].pair;
    return p.image_id1 == id ? p.image_id2 : p.image_id1;
  }
  /// The edges' pairs, in edge order (ascending pair).
  std::vector<ImagePair> Pairs() const;
  /// Weight of the edge between a and b, 0 if there is none.
  uint32_t Weight(ImageId a, ImageId b) const;

 private:
  void BuildAdjacency();

  std::vector<ImageId> images_;
  std::unordered_map<ImageId, size_t> index_;
  std::vector<ViewGraphEdge> edges_;
  std::vector<std::vector<size_t>> adjacency_;
};

/// The `count` strongest neighbours of `image_id` (by decreasing weight;
/// equal weights: smaller image id first), leaving out `exclude`
/// (kInvalidImageId: none). Fewer if the image has fewer neighbours; none
/// for an unknown image.
std::vector<ImageId> StrongestNeighbours(const ViewGraph& graph,
                                         ImageId image_id, size_t count,
                                         ImageId exclude = kInvalidImageId);

/// The `count` strongest edges (indices into graph.Edges()) incident to the
/// image with dense index `index`, in the order of StrongestNeighbours.
std::vector<size_t> StrongestEdges(const ViewGraph& graph, size_t index,
                                   size_t count);

/// Per edge of `graph` (in Edges() order), its mutual rank: the larger,
/// over its two images, of its place among that image's edges by weight
/// (1 = the strongest; ties as StrongestEdges). An edge of mutual rank r
/// is among the r strongest pairs of both its images (mutual r-nearest
/// neighbours).
std::vector<uint32_t> MutualRanks(const ViewGraph& graph);

/// The pairs of the edges of mutual rank at most `max_rank` (MutualRanks):
/// each among the `max_rank` strongest pairs of both its images. Empty for
/// `max_rank` 0.
std::set<ImagePair> PairsOfMutualRankAtMost(const ViewGraph& graph,
                                            uint32_t max_rank);

}  // namespace hisfm
