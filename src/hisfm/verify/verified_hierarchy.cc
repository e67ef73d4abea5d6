#include "hisfm/verify/verified_hierarchy.h"

#include <algorithm>
#include <set>

#include "hisfm/util/error.h"
#include "hisfm/util/logging.h"

namespace hisfm {

void VerifiedHierarchyOptions::Check() const {
  trusted_edges.Check();
  HISFM_CHECK_OPTION(trusted_keep_rank, trusted_keep_rank >= 0, ">= 0");
  HISFM_CHECK_OPTION(support_edges, support_edges >= 0, ">= 0");
  HISFM_CHECK_OPTION(support_threshold,
                     support_threshold >= 0 && support_threshold <= 1,
                     "in [0, 1]");
}

size_t AddSupportEdges(const ViewGraph& graph, BridgeScorer& verifier,
                     int count, double threshold, Hierarchy* hierarchy,
                     std::vector<ViewGraphEdge>* reserve,
                     double reserve_threshold) {
  if (count <= 0) return 0;
  std::unordered_map<ImageId, size_t> component_of;
  for (size_t c = 0; c < hierarchy->components.size(); ++c) {
    for (const ImageId id : hierarchy->components[c].images) {
      component_of[id] = c;
    }
  }
  std::set<ImagePair> present;
  for (const ImagePair& p : hierarchy->Edges()) present.insert(p);
  // The pairs to score, in the order they are met (a pair can be among the
  // strongest of both its images: it is scored once), with the image that
  // met it and its component.
  struct Candidate {
    size_t edge;
    ImageId id;
    size_t component;
  };
  std::vector<Candidate> candidates;
  std::vector<ImagePair> pairs;
  std::set<ImagePair> judged;
  for (size_t i = 0; i < graph.NumImages(); ++i) {
    const ImageId id = graph.Images()[i];
    auto ci = component_of.find(id);
    if (ci == component_of.end()) continue;
    for (const size_t e : StrongestEdges(graph, i, count)) {
      const ViewGraphEdge& edge = graph.Edges()[e];
      auto co = component_of.find(graph.OtherEnd(e, id));
      if (co == component_of.end() || co->second != ci->second ||
          present.count(edge.pair) || !judged.insert(edge.pair).second) {
        continue;
      }
      candidates.push_back({e, id, ci->second});
      pairs.push_back(edge.pair);
    }
  }
  if (pairs.empty()) return 0;
  // One batch: the scorer may judge the pairs in parallel.
  const std::vector<double> scores = verifier.Score(pairs);
  ThrowUnless(scores.size() == pairs.size(),
              "verifier returned a wrong number of scores");
  for (size_t k = 0; k < candidates.size(); ++k) {
    const ViewGraphEdge& edge = graph.Edges()[candidates[k].edge];
    const ImageId id = candidates[k].id;
    const ImageId other = graph.OtherEnd(candidates[k].edge, id);
    const double score = scores[k];
    if (score < threshold) {
      if (reserve && score >= reserve_threshold) {
        reserve->push_back(edge);
      }
      continue;
    }
    hierarchy->support_edges.push_back(edge);
    HierarchyComponent& comp = hierarchy->components[candidates[k].component];
    comp.edges.insert(
        std::lower_bound(comp.edges.begin(), comp.edges.end(), edge.pair),
        edge.pair);
    if (std::binary_search(comp.skeleton_images.begin(),
                           comp.skeleton_images.end(), id) &&
        std::binary_search(comp.skeleton_images.begin(),
                           comp.skeleton_images.end(), other)) {
      comp.skeleton_edges.insert(
          std::lower_bound(comp.skeleton_edges.begin(),
                           comp.skeleton_edges.end(), edge.pair),
          edge.pair);
    }
  }
  return pairs.size();
}

VerifiedHierarchy BuildVerifiedHierarchy(
    const ViewGraph& graph, MultiViewVerifier& verifier,
    const HierarchyOptions& hierarchy_options,
    const VerifiedHierarchyOptions& options,
    const std::set<ImagePair>* pre_verified) {
  options.Check();
  // The pairs among the few strongest of both their images
  // (VerifiedHierarchyOptions::trusted_keep_rank).
  const std::set<ImagePair> kept_by_rank = PairsOfMutualRankAtMost(
      graph, static_cast<uint32_t>(options.trusted_keep_rank));
  const std::set<ImagePair> none;
  const std::set<ImagePair>& accepted = pre_verified ? *pre_verified : none;
  std::set<ImagePair> answered;
  PreVerifiedScorer scorer(std::make_shared<BorrowedScorer>(&verifier),
                           &accepted, &answered);
  VerifiedHierarchy out;
  static_cast<JudgedHierarchy&>(out) = BuildHierarchyJudgingTrustedEdges(
      graph,
      [&scorer](const Communities&) -> std::unique_ptr<BridgeScorer> {
        return std::make_unique<BorrowedScorer>(&scorer);
      },
      hierarchy_options, options.trusted_edges,
      // Only the test's evidence removes a trusted edge: a pair it could
      // not judge keeps the trust the paper gives it, and so does a pair
      // among the strongest of both its images or a pre-verified one.
      [&verifier, &kept_by_rank, &accepted](const ImagePair& pair) {
        return !kept_by_rank.count(pair) && !accepted.count(pair) &&
               verifier.Features(pair).Speaks();
      });
  AddSupportEdges(out.graph, scorer, options.support_edges,
                  options.support_threshold, &out.hierarchy, &out.reserve_edges,
                  hierarchy_options.skeleton.verify_threshold);
  if (options.clean_inliers) {
    std::vector<ImagePair> used = out.hierarchy.Edges();
    for (const ViewGraphEdge& e : out.reserve_edges) used.push_back(e.pair);
    CleanInliers(used, verifier, &out.inliers, &out.num_inliers_before,
                 &out.num_inliers_after, &accepted);
  }
  out.num_pre_verified = answered.size();
  return out;
}

void CleanInliers(const std::vector<ImagePair>& pairs,
                  MultiViewVerifier& verifier,
                  std::unordered_map<ImagePair, std::vector<FeatureMatch>,
                                     ImagePairHash>* inliers,
                  size_t* before, size_t* after,
                  const std::set<ImagePair>* skip) {
  for (const ImagePair& pair : pairs) {
    if (skip && skip->count(pair)) continue;
    std::vector<FeatureMatch> kept = verifier.ConsistentInliers(pair);
    *before +=
        verifier.cache().Pair(pair.image_id1, pair.image_id2)->matches.size();
    *after += kept.size();
    inliers->insert_or_assign(pair, std::move(kept));
  }
}

}  // namespace hisfm
