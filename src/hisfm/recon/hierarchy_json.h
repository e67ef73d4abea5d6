// The hierarchy as JSON (view_graph.json, `hisfm view_graph`, the report):
// the graph layer itself knows no JSON.
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <unordered_map>

#include "hisfm/graph/hierarchy.h"
#include "hisfm/graph/trusted_edges.h"
#include "hisfm/graph/view_graph.h"

namespace hisfm {

/// JSON description: community of each image, skeleton bridges with scores,
/// intra-community skeleton edges, leaf edges, rejected bridges, components.
/// A bridge's "score" is null if it was rejected by its cycle before being
/// scored; "cycle_error_deg" is present where a cycle was checked
/// (SkeletonOptions::max_cycle_rotation_deg); "outvoted": true marks a
/// rejected bridge the near misses or peers refused though its score passed
/// (SkeletonOptions::near_miss_vote, peer_vote_size; its cycle_error_deg is
/// then the largest cycle it closed with them).
/// `image_names` maps ids to names (may be empty).
nlohmann::json HierarchyToJson(
    const Hierarchy& hierarchy, const ViewGraph& graph,
    const std::unordered_map<ImageId, std::string>& image_names);

/// The trusted edges the verifier rejected (graph/trusted_edges.h), as a
/// JSON array of {image_id1, image_id2, inliers, score, round}, in the
/// order they were rejected.
nlohmann::json RejectedTrustedEdgesToJson(
    const std::vector<RejectedTrustedEdge>& rejected);

}  // namespace hisfm
