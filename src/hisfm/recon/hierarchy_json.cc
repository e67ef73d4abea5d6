#include "hisfm/recon/hierarchy_json.h"

namespace hisfm {

namespace {

const char* RoleName(BridgeRole role) {
  switch (role) {
    case BridgeRole::kTree:
      return "tree";
    case BridgeRole::kTopWeight:
      return "top_weight";
    case BridgeRole::kBackup:
      return "backup";
    case BridgeRole::kConnectivity:
      return "connectivity";
    case BridgeRole::kFallback:
      return "fallback";
  }
  return "tree";
}

nlohmann::json BridgeToJson(const BridgeRecord& b) {
  nlohmann::json j = {
      {"image_id1", b.pair.image_id1}, {"image_id2", b.pair.image_id2},
      {"community1", b.community1},   {"community2", b.community2},
      {"inliers", b.weight},
      {"score", b.score >= 0 ? nlohmann::json(b.score) : nlohmann::json()},
      {"role", RoleName(b.role)},     {"tree", b.tree}};
  if (b.cycle_error_deg >= 0) j["cycle_error_deg"] = b.cycle_error_deg;
  if (b.outvoted) j["outvoted"] = true;
  if (b.rank > 0) j["rank"] = b.rank;
  return j;
}

nlohmann::json EdgeToJson(const ViewGraphEdge& e) {
  return {{"image_id1", e.pair.image_id1},
          {"image_id2", e.pair.image_id2},
          {"inliers", e.weight}};
}

}  // namespace

nlohmann::json HierarchyToJson(
    const Hierarchy& h, const ViewGraph& graph,
    const std::unordered_map<ImageId, std::string>& image_names) {
  nlohmann::json images = nlohmann::json::array();
  for (ImageId id : graph.Images()) {
    auto it = image_names.find(id);
    images.push_back({{"image_id", id},
                      {"name", it == image_names.end() ? "" : it->second},
                      {"community", h.communities.Of(id)},
                      {"skeletal", h.skeleton.Contains(id)}});
  }
  nlohmann::json bridges = nlohmann::json::array();
  for (const BridgeRecord& b : h.skeleton.bridges)
    bridges.push_back(BridgeToJson(b));
  nlohmann::json rejected = nlohmann::json::array();
  for (const BridgeRecord& b : h.skeleton.rejected)
    rejected.push_back(BridgeToJson(b));
  nlohmann::json intra = nlohmann::json::array();
  for (const ViewGraphEdge& e : h.skeleton.intra_edges)
    intra.push_back(EdgeToJson(e));
  nlohmann::json leaves = nlohmann::json::array();
  for (const ViewGraphEdge& e : h.leaf_edges) leaves.push_back(EdgeToJson(e));
  nlohmann::json support = nlohmann::json::array();
  for (const ViewGraphEdge& e : h.support_edges) {
    support.push_back(EdgeToJson(e));
  }
  nlohmann::json components = nlohmann::json::array();
  for (const HierarchyComponent& c : h.components) {
    components.push_back({{"images", c.images},
                          {"skeleton_images", c.skeleton_images},
                          {"num_edges", c.edges.size()}});
  }
  return {{"num_images", graph.NumImages()},
          {"num_verified_pairs", graph.NumEdges()},
          {"num_communities", h.communities.NumCommunities()},
          {"num_trees", h.skeleton.num_trees},
          {"num_candidate_bridges", h.skeleton.num_candidate_bridges},
          {"num_rank_excluded_bridges", h.skeleton.num_rank_excluded},
          {"num_outvoted_bridges", h.skeleton.num_outvoted},
          {"num_verified_bridges", h.skeleton.num_verified},
          {"num_verified_first_tree", h.skeleton.num_verified_first_tree},
          {"images", images},
          {"skeleton_bridges", bridges},
          {"rejected_bridges", rejected},
          {"skeleton_intra_edges", intra},
          {"leaf_edges", leaves},
          {"support_edges", support},
          {"components", components},
          {"isolated_images", h.isolated_images}};
}

nlohmann::json RejectedTrustedEdgesToJson(
    const std::vector<RejectedTrustedEdge>& rejected) {
  nlohmann::json out = nlohmann::json::array();
  for (const RejectedTrustedEdge& e : rejected) {
    out.push_back({{"image_id1", e.pair.image_id1},
                   {"image_id2", e.pair.image_id2},
                   {"inliers", e.weight},
                   {"score", e.score},
                   {"round", e.round}});
  }
  return out;
}

}  // namespace hisfm
