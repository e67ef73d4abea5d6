// Leaf attachment.
//
// HiSfM paper, Sec. III-C: every image outside the skeleton (a leaf) is
// attached by a few strongest intra-community edges, preferring edges to
// skeletal images of the same community; no verification is needed since
// communities come from strong top-k relations.
#pragma once

#include <vector>

#include "hisfm/graph/communities.h"
#include "hisfm/graph/skeleton.h"
#include "hisfm/graph/view_graph.h"

namespace hisfm {

struct LeafOptions {
  /// Edges per leaf to skeletal images of its community (strongest first).
  int leaf_edges = 2;
  /// Additional leaf-to-leaf edges per leaf inside its community, for local
  /// support (strongest first).
  int leaf_leaf_edges = 1;
  /// Always keep the leaf's top-k community edges, which guarantees that every
  /// leaf is connected to its community's scaffold.
  bool keep_top_k_edges = true;

  void Check() const;
};

/// The attachment edges E_l (sorted, unique): each has at least one leaf end
/// and both ends in the same community.
std::vector<ViewGraphEdge> AttachLeaves(const ViewGraph& graph,
                                        const Communities& communities,
                                        const Skeleton& skeleton,
                                        const LeafOptions& options);

}  // namespace hisfm
