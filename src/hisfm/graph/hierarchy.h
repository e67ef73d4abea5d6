// The hierarchical reconstruction graph H = (V, E_s + E_l) of HiSfM (paper,
// Sec. III-A to III-C): communities, the verified skeleton, and leaf
// attachments, split into connected components (one model each).
#pragma once

#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "hisfm/graph/communities.h"
#include "hisfm/graph/leaves.h"
#include "hisfm/graph/skeleton.h"
#include "hisfm/graph/view_graph.h"

namespace hisfm {

struct HierarchyOptions {
  CommunityOptions communities;
  SkeletonOptions skeleton;
  LeafOptions leaves;

  void Check() const;
};

/// One connected component of H: it becomes one model.
struct HierarchyComponent {
  /// All images of the component, sorted.
  std::vector<ImageId> images;
  /// Its skeletal images (the scaffold), sorted.
  std::vector<ImageId> skeleton_images;
  /// Its edges of H (skeleton and leaves), sorted.
  std::vector<ImagePair> edges;
  /// Its skeleton edges, sorted.
  std::vector<ImagePair> skeleton_edges;
};

/// The full hierarchy.
struct Hierarchy {
  Communities communities;
  Skeleton skeleton;
  std::vector<ViewGraphEdge> leaf_edges;
  /// Verified edges added inside components to densify the reconstruction
  /// (not part of the paper's hierarchy; see verified_hierarchy.h). Those
  /// between two skeletal images are in their component's skeleton_edges.
  std::vector<ViewGraphEdge> support_edges;
  /// Components of H with at least two images, largest first.
  std::vector<HierarchyComponent> components;
  /// Images without any verified pair (not registered).
  std::vector<ImageId> isolated_images;

  /// E_H = E_s + E_l (+ support edges), sorted and unique.
  std::vector<ImagePair> Edges() const;
};

/// Builds communities, skeleton and leaves. `scorer` may be null.
Hierarchy BuildHierarchy(const ViewGraph& graph, BridgeScorer* scorer,
                         const HierarchyOptions& options);

/// Makes the bridge scorer once the communities are known (a verifier may use
/// them as context); may return null (accept every bridge).
using ScorerFactory =
    std::function<std::unique_ptr<BridgeScorer>(const Communities&)>;

/// As above, creating the scorer from the communities; the scorer is kept
/// alive only during the build.
Hierarchy BuildHierarchy(const ViewGraph& graph,
                         const ScorerFactory& make_scorer,
                         const HierarchyOptions& options);

}  // namespace hisfm
