#include "hisfm/graph/skeleton.h"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <queue>
#include <set>
#include <string>
#include <unordered_map>

#include "hisfm/graph/min_cut.h"
#include "hisfm/graph/union_find.h"
#include "hisfm/util/error.h"
#include "hisfm/util/logging.h"
#include "hisfm/util/timer.h"

namespace hisfm {

void SkeletonOptions::Check() const {
  HISFM_CHECK_OPTION(num_trees, num_trees >= 0, ">= 0");
  HISFM_CHECK_OPTION(images_per_tree, images_per_tree >= 1, ">= 1");
  HISFM_CHECK_OPTION(verify_threshold,
                     verify_threshold >= 0.0 && verify_threshold <= 1.0,
                     "in [0.0, 1.0]");
  HISFM_CHECK_OPTION(num_top_bridges, num_top_bridges >= 0, ">= 0");
  HISFM_CHECK_OPTION(num_backup_bridges, num_backup_bridges >= 0, ">= 0");
  HISFM_CHECK_OPTION(weak_link_max_inliers, weak_link_max_inliers >= 0, ">= 0");
  HISFM_CHECK_OPTION(max_verify_batch_size, max_verify_batch_size >= 1, ">= 1");
  HISFM_CHECK_OPTION(redundant_threshold,
                     redundant_threshold >= 0.0 && redundant_threshold <= 1.0,
                     "in [0.0, 1.0]");
  HISFM_CHECK_OPTION(redundant_budget_trees,
                     redundant_budget_trees >= 0 &&
                         std::isfinite(redundant_budget_trees),
                     ">= 0 and finite");
  HISFM_CHECK_OPTION(first_tree_budget_trees,
                     first_tree_budget_trees >= 0 &&
                         std::isfinite(first_tree_budget_trees),
                     ">= 0 and finite");
  HISFM_CHECK_OPTION(fallback_threshold,
                     fallback_threshold >= 0.0 && fallback_threshold <= 1.0,
                     "in [0.0, 1.0]");
  HISFM_CHECK_OPTION(max_cycle_rotation_deg,
                     max_cycle_rotation_deg >= 0.0 &&
                         max_cycle_rotation_deg <= 180.0,
                     "in [0.0, 180.0]");
  HISFM_CHECK_OPTION(peer_vote_size, peer_vote_size >= 0, ">= 0");
  HISFM_CHECK_OPTION(rank_tiers, rank_tiers >= 0, ">= 0");
  HISFM_CHECK_OPTION(max_bridge_rank, max_bridge_rank >= 0, ">= 0");
}

double SkeletonOptions::ThresholdFor(BridgeRole role, int tree) const {
  if (role == BridgeRole::kTree && tree == 0) return verify_threshold;
  if (role == BridgeRole::kFallback) return fallback_threshold;
  return std::max(verify_threshold, redundant_threshold);
}

int SkeletonOptions::NumTreesFor(size_t num_images) const {
  if (num_trees > 0) return num_trees;
  return std::max(1, static_cast<int>(std::lround(
                         static_cast<double>(num_images) / images_per_tree)));
}

std::vector<ImagePair> Skeleton::Edges() const {
  std::vector<ImagePair> out;
  for (const BridgeRecord& b : bridges) out.push_back(b.pair);
  for (const ViewGraphEdge& e : intra_edges) out.push_back(e.pair);
  std::sort(out.begin(), out.end());
  out.erase(std::unique(out.begin(), out.end()), out.end());
  return out;
}

bool Skeleton::Contains(ImageId id) const {
  return std::binary_search(images.begin(), images.end(), id);
}

namespace {

using CommunityPair = std::pair<CommunityId, CommunityId>;

CommunityPair MakeCommunityPair(CommunityId a, CommunityId b) {
  return a < b ? CommunityPair(a, b) : CommunityPair(b, a);
}

struct CommunityPairHash {
  size_t operator()(const CommunityPair& p) const {
    return std::hash<uint64_t>()((static_cast<uint64_t>(p.first) << 32) |
                                 p.second);
  }
};

struct Bridge {
  ImagePair pair;
  CommunityId c1;
  CommunityId c2;
  uint32_t weight;
  // Dense id of the bridge's community pair.
  uint32_t kappa;
  // The larger of the pair's ranks among its two images' pairs by weight
  // (1 = strongest; SkeletonOptions::rank_tiers).
  uint32_t rank = 0;
};

constexpr double kNotScored = -1.0;
// Candidates a speculative batch looks through, at most.
constexpr size_t kMaxLookahead = 4096;

// Lazily scores bridges (by index into the sorted bridge list), each at most
// once, counting work.
class ScoreCache {
 public:
  ScoreCache(const std::vector<Bridge>& bridges, BridgeScorer* scorer,
             Skeleton* skeleton)
      : bridges_(bridges),
        scorer_(scorer),
        skeleton_(skeleton),
        scores_(bridges.size(), kNotScored) {}

  bool Has(size_t k) const { return scores_[k] != kNotScored; }

  // Scores the bridges `ks` that are not cached yet, in one call.
  void Fill(const std::vector<size_t>& ks) {
    std::vector<size_t> todo;
    std::vector<ImagePair> pairs;
    for (size_t k : ks) {
      if (!Has(k)) {
        todo.push_back(k);
        pairs.push_back(bridges_[k].pair);
      }
    }
    if (todo.empty()) return;
    std::vector<double> s = scorer_ ? scorer_->Score(pairs)
                                    : std::vector<double>(pairs.size(), 1.0);
    if (s.size() != todo.size()) {
      throw Error("verifier returned a wrong number of scores");
    }
    for (size_t i = 0; i < todo.size(); ++i) {
      if (!std::isfinite(s[i])) {
        throw Error("verifier returned a non-finite score");
      }
      scores_[todo[i]] = std::clamp(s[i], 0.0, 1.0);
    }
    skeleton_->num_verified += todo.size();
    ++skeleton_->num_scorer_calls;
  }

  double Get(size_t k) {
    if (!Has(k)) Fill({k});
    return scores_[k];
  }

 private:
  const std::vector<Bridge>& bridges_;
  BridgeScorer* scorer_;
  Skeleton* skeleton_;
  std::vector<double> scores_;
};

BridgeRecord MakeRecord(const Bridge& b, double score, bool accepted,
                        BridgeRole role, int tree) {
  BridgeRecord r;
  r.pair = b.pair;
  r.community1 = b.c1;
  r.community2 = b.c2;
  r.weight = b.weight;
  r.rank = b.rank;
  r.score = score;
  r.accepted = accepted;
  r.role = role;
  r.tree = tree;
  return r;
}

// The maximum spanning tree of one community's induced subgraph (`edges`,
// indices into graph.Edges()), as adjacency lists over the community's
// members (`local` maps an image to its member index). An edge weighs its
// view-graph weight times scorer->ConsistentShare when `scorer` is given:
// Kruskal over a max-heap keyed by the weight as far as it is known (the
// view-graph weight bounds the scaled one from above), so a share is asked
// only of an edge that reaches the top of the heap while its images are
// still apart, and once. Shares in `known` are used without asking.
std::vector<std::vector<std::pair<size_t, size_t>>> CommunitySpanningTree(
    const ViewGraph& graph, const std::vector<size_t>& edges,
    const std::unordered_map<ImageId, size_t>& local, size_t num_members,
    BridgeScorer* scorer, const PairScores& known = {}) {
  struct Entry {
    double weight;
    bool exact;
    size_t edge;
    bool operator<(const Entry& o) const {
      if (weight != o.weight) return weight < o.weight;
      if (exact != o.exact) return !exact;  // an exact weight first on ties
      return edge > o.edge;
    }
  };
  std::priority_queue<Entry> heap;
  for (size_t e : edges) {
    heap.push({static_cast<double>(graph.Edges()[e].weight), scorer == nullptr,
               e});
  }
  UnionFind uf(num_members);
  std::vector<std::vector<std::pair<size_t, size_t>>> tree(num_members);
  while (!heap.empty()) {
    const Entry top = heap.top();
    heap.pop();
    const ImagePair& p = graph.Edges()[top.edge].pair;
    const size_t a = local.at(p.image_id1);
    const size_t b = local.at(p.image_id2);
    if (uf.Connected(a, b)) continue;
    if (!top.exact) {
      // A share outside [0, 1] is clamped; NaN counts as 0 (it would break
      // the heap's order).
      const auto it = known.find(p);
      const double reported =
          it != known.end() ? it->second : scorer->ConsistentShare(p);
      const double share =
          std::isnan(reported) ? 0.0 : std::clamp(reported, 0.0, 1.0);
      heap.push({top.weight * share, true, top.edge});
      continue;
    }
    uf.Union(a, b);
    tree[a].push_back({b, top.edge});
    tree[b].push_back({a, top.edge});
  }
  return tree;
}

// Image id -> index among `members`.
std::unordered_map<ImageId, size_t> MemberIndex(
    const std::vector<ImageId>& members) {
  std::unordered_map<ImageId, size_t> local;
  for (size_t i = 0; i < members.size(); ++i) local[members[i]] = i;
  return local;
}

// Joins the skeletal images of each community: the maximum spanning tree of
// the community's induced subgraph (CommunitySpanningTree), pruned of
// non-skeletal leaves, i.e. the smallest subtree that connects them. A
// community with no skeletal image keeps its whole maximum spanning tree.
// With a scorer, the shares of every tree's edges by view-graph weight are
// asked first, in one batch (ConsistentShares, judged in parallel by the
// builtin): the lazy tree asks each of them anyway (an edge of the
// maximum spanning tree by the upper bounds is the heaviest link across
// some cut, so it reaches the top of the heap while its images are apart).
std::vector<ViewGraphEdge> ConnectSkeletalImages(
    const ViewGraph& graph, const Communities& communities,
    const std::set<ImageId>& skeletal, BridgeScorer* scorer) {
  std::vector<ViewGraphEdge> out;
  std::vector<std::vector<size_t>> community_edges(
      communities.NumCommunities());
  for (size_t e = 0; e < graph.NumEdges(); ++e) {
    const ImagePair& p = graph.Edges()[e].pair;
    const CommunityId c = communities.Of(p.image_id1);
    if (c == communities.Of(p.image_id2)) community_edges[c].push_back(e);
  }
  // A community without any bridge (alone in its component, or cut off by
  // rejected bridges) becomes a scaffold of its own: keep its whole tree.
  // One with a single skeletal image needs none.
  std::vector<size_t> num_skeletal(communities.NumCommunities(), 0);
  for (CommunityId c = 0; c < communities.NumCommunities(); ++c) {
    for (ImageId id : communities.members[c]) {
      num_skeletal[c] += skeletal.count(id);
    }
  }
  auto needs_tree = [&](CommunityId c) {
    return communities.members[c].size() >= 2 && num_skeletal[c] != 1;
  };
  PairScores known;
  if (scorer != nullptr) {
    std::vector<ImagePair> batch;
    for (CommunityId c = 0; c < communities.NumCommunities(); ++c) {
      if (!needs_tree(c)) continue;
      const std::vector<ImageId>& members = communities.members[c];
      const std::vector<std::vector<std::pair<size_t, size_t>>> bound =
          CommunitySpanningTree(graph, community_edges[c],
                                MemberIndex(members), members.size(), nullptr);
      for (size_t i = 0; i < members.size(); ++i) {
        for (const auto& [j, e] : bound[i]) {
          if (i < j) batch.push_back(graph.Edges()[e].pair);
        }
      }
    }
    const std::vector<double> shares = scorer->ConsistentShares(batch);
    if (shares.size() != batch.size()) {
      throw Error("scorer " + scorer->Name() + " returned " +
                  std::to_string(shares.size()) + " consistent shares for " +
                  std::to_string(batch.size()) + " pairs");
    }
    for (size_t k = 0; k < batch.size(); ++k) known[batch[k]] = shares[k];
  }
  for (CommunityId c = 0; c < communities.NumCommunities(); ++c) {
    if (!needs_tree(c)) continue;
    const std::vector<ImageId>& members = communities.members[c];
    const bool keep_all = num_skeletal[c] == 0;
    auto is_terminal = [&](ImageId id) {
      return keep_all || skeletal.count(id) > 0;
    };
    const std::vector<std::vector<std::pair<size_t, size_t>>> tree =
        CommunitySpanningTree(graph, community_edges[c], MemberIndex(members),
                              members.size(), scorer, known);
    // Prune non-skeletal leaves until none is left.
    std::vector<size_t> degree(members.size());
    std::vector<bool> removed(members.size(), false);
    std::vector<size_t> stack;
    for (size_t i = 0; i < members.size(); ++i) {
      degree[i] = tree[i].size();
      if (degree[i] <= 1 && !is_terminal(members[i])) stack.push_back(i);
    }
    while (!stack.empty()) {
      const size_t i = stack.back();
      stack.pop_back();
      if (removed[i]) continue;
      removed[i] = true;
      for (const auto& [j, e] : tree[i]) {
        if (removed[j]) continue;
        if (--degree[j] <= 1 && !is_terminal(members[j])) stack.push_back(j);
      }
    }
    for (size_t i = 0; i < members.size(); ++i) {
      if (removed[i]) continue;
      for (const auto& [j, e] : tree[i]) {
        if (!removed[j] && i < j) out.push_back(graph.Edges()[e]);
      }
    }
  }
  std::sort(out.begin(), out.end(),
            [](const ViewGraphEdge& a, const ViewGraphEdge& b) {
              return a.pair < b.pair;
            });
  return out;
}

// Adds verified bridges across minimum cuts of the skeleton's community graph
// until each component of the full community graph is K-edge-connected.
// `used[kappa]` marks the community pairs of the skeleton, `kappas` lists
// them by dense id.
// `admit(k, role)` verifies bridge k if the budget allows (recording a
// rejection) and returns whether it may be taken; `take(k)` takes it.
template <typename AdmitFn, typename TakeFn>
void RestoreConnectivityAcrossCuts(const std::vector<Bridge>& bridges,
                                   size_t m, int K,
                                   const std::vector<CommunityPair>& kappas,
                                   const SkeletonOptions& options,
                                   ScoreCache* cache, std::vector<char>* used,
                                   AdmitFn&& admit, TakeFn&& take) {
  UnionFind all(m);
  for (const Bridge& b : bridges) all.Union(b.c1, b.c2);
  // Bridges that may still be taken: not rejected for their score (a
  // rejected one would only be skipped again; admit() also refuses those
  // its cycle rejected), in weight order; and the used community pairs,
  // ascending.
  std::vector<size_t> open;
  for (size_t k = 0; k < bridges.size(); ++k) {
    if (!cache->Has(k) ||
        cache->Get(k) >= options.ThresholdFor(BridgeRole::kConnectivity, -1)) {
      open.push_back(k);
    }
  }
  std::vector<uint32_t> used_kappas;
  for (size_t kappa = 0; kappa < kappas.size(); ++kappa) {
    if ((*used)[kappa]) used_kappas.push_back(static_cast<uint32_t>(kappa));
  }
  std::map<size_t, std::vector<CommunityId>> components;
  for (CommunityId c = 0; c < m; ++c) components[all.Find(c)].push_back(c);
  std::vector<size_t> local(m, 0);
  for (const auto& [root, members] : components) {
    if (members.size() < 2) continue;
    for (size_t i = 0; i < members.size(); ++i) local[members[i]] = i;
    const size_t component_root = root;
    auto in_component = [&](CommunityId c) {
      return all.Find(c) == component_root;
    };
    for (size_t iteration = 0; iteration < K * members.size(); ++iteration) {
      std::vector<std::pair<size_t, size_t>> edges;
      for (const uint32_t kappa : used_kappas) {
        if (in_component(kappas[kappa].first)) {
          edges.push_back(
              {local[kappas[kappa].first], local[kappas[kappa].second]});
        }
      }
      const MinCut cut = GlobalMinCut(members.size(), edges, K);
      if (cut.value >= static_cast<size_t>(K)) break;
      std::vector<bool> in_side(members.size(), false);
      for (size_t v : cut.side) in_side[v] = true;
      bool added = false;
      for (const size_t k : open) {
        const Bridge& b = bridges[k];
        if (!in_component(b.c1)) continue;
        if (in_side[local[b.c1]] == in_side[local[b.c2]] ||
            (*used)[b.kappa]) {
          continue;
        }
        // (A bridge rejected here is recorded once; its score stays cached.)
        if (!admit(k, BridgeRole::kConnectivity)) continue;
        (*used)[b.kappa] = 1;
        // (Kept in ascending order: the cut's input does not change.)
        used_kappas.insert(std::lower_bound(used_kappas.begin(),
                                            used_kappas.end(), b.kappa),
                           b.kappa);
        take(k);
        added = true;
        break;
      }
      if (!added) break;
    }
  }
}

// The state of one skeleton build: the bridges in Kruskal's order, their
// community pairs, the lazily filled scores and what has been taken or
// rejected. Each step of BuildSkeleton is a method.
class SkeletonBuilder {
 public:
  SkeletonBuilder(const ViewGraph& graph, const Communities& communities,
                  BridgeScorer* scorer, const SkeletonOptions& options)
      : options_(options),
        m_(communities.NumCommunities()),
        scorer_(scorer),
        held_communities_(communities.NumCommunities()) {
    skeleton_.num_trees = options.NumTreesFor(graph.NumImages());
    const std::vector<uint32_t> ranks =
        options.rank_tiers > 0 || options.max_bridge_rank > 0
            ? MutualRanks(graph)
            : std::vector<uint32_t>();
    for (size_t k = 0; k < graph.NumEdges(); ++k) {
      const ViewGraphEdge& e = graph.Edges()[k];
      const CommunityId a = communities.Of(e.pair.image_id1);
      const CommunityId b = communities.Of(e.pair.image_id2);
      if (a == b) continue;
      const uint32_t rank = ranks.empty() ? 0 : ranks[k];
      if (options.max_bridge_rank > 0 &&
          rank > static_cast<uint32_t>(options.max_bridge_rank)) {
        ++skeleton_.num_rank_excluded;
        continue;
      }
      bridges_.push_back({e.pair, a, b, e.weight, 0, rank});
    }
    std::stable_sort(bridges_.begin(), bridges_.end(),
                     [](const Bridge& x, const Bridge& y) {
                       return x.weight > y.weight;
                     });
    skeleton_.num_candidate_bridges =
        bridges_.size() + skeleton_.num_rank_excluded;
    for (Bridge& b : bridges_) {
      const CommunityPair kappa = MakeCommunityPair(b.c1, b.c2);
      auto [it, inserted] =
          kappa_ids_.emplace(kappa, static_cast<uint32_t>(kappas_.size()));
      if (inserted) kappas_.push_back(kappa);
      b.kappa = it->second;
    }
    used_.assign(kappas_.size(), 0);
    for (const ViewGraphEdge& e : communities.top_k_edges) Link(e.pair);
    rejected_seen_.assign(bridges_.size(), 0);
    in_skeleton_.assign(bridges_.size(), 0);
    cycle_error_.assign(bridges_.size(), -1.0);
    outvoted_.assign(bridges_.size(), 0);
    if (options.peer_vote_size > 0) {
      community_bridges_.resize(m_);
      for (size_t k = 0; k < bridges_.size(); ++k) {
        community_bridges_[bridges_[k].c1].push_back(k);
        community_bridges_[bridges_[k].c2].push_back(k);
      }
    }
    cache_ = std::make_unique<ScoreCache>(bridges_, scorer, &skeleton_);
  }

  // Algorithm 1: K greedy trees; returns whether every tree spans.
  bool PackTrees();
  // Bridge indices in the order the trees meet them (rank tiers, then
  // weight; SkeletonOptions::rank_tiers).
  std::vector<size_t> TreeOrder() const;
  // Verified bridges across minimum cuts until K-edge-connected.
  void RestoreConnectivity();
  // Verified parallel bridges for tree bridges with few inliers.
  void AddBackupBridges();
  // Verified top-weight bridges on community pairs not used yet.
  void AddTopWeightBridges();
  // Joins communities the trees left apart through the best-scoring bridges
  // already scored, if they reach fallback_threshold.
  void AddFallbackBridges();
  // Speculative batch: scores the next bridges from candidates[i] on that
  // Kruskal meets if every one before them is rejected, at most `want`
  // (as many as the current run of rejections, so a scene where most
  // bridges pass stays lazy). They remain valid candidates whatever the
  // outcome, unless an earlier one in the batch is taken.
  void FillSpeculativeBatch(const std::vector<size_t>& candidates, size_t i,
                            UnionFind* uf, size_t want);
  // The first tree's budget is spent: the near misses met so far join the
  // parts of `uf` they can, and the tree goes on at the fallback threshold
  // (SkeletonOptions::first_tree_budget_trees). Returns the bridges taken.
  size_t GoOnAtFallback(UnionFind* uf, size_t tree_size,
                        size_t max_tree_edges);
  // Joins the parts of `uf` through the bridges already scored in
  // [fallback_threshold, verify_threshold), best first, unless their near
  // misses outvote them; with `last_resort`, the best one between parts
  // whose candidates were all outvoted too. Returns the bridges taken.
  size_t JoinThroughNearMisses(UnionFind* uf, bool last_resort);
  // Joins each community's skeletal images; returns the skeleton.
  Skeleton Finish(const ViewGraph& graph, const Communities& communities);

 private:
  void Reject(size_t k, double score, BridgeRole role,
              double cycle_error_deg = -1.0) {
    if (!rejected_seen_[k]) {
      rejected_seen_[k] = 1;
      skeleton_.rejected.push_back(
          MakeRecord(bridges_[k], score, false, role, -1));
      skeleton_.rejected.back().cycle_error_deg = cycle_error_deg;
    }
  }
  void Take(size_t k, double score, BridgeRole role, int tree) {
    in_skeleton_[k] = 1;
    skeleton_.bridges.push_back(MakeRecord(bridges_[k], score, true, role,
                                           tree));
    skeleton_.bridges.back().cycle_error_deg = cycle_error_[k];
    Link(bridges_[k].pair);
    held_communities_.Union(bridges_[k].c1, bridges_[k].c2);
  }
  // Adds an edge to the image graph of what the skeleton holds.
  void Link(const ImagePair& p) {
    held_[p.image_id1].push_back(p.image_id2);
    held_[p.image_id2].push_back(p.image_id1);
  }
  // Breadth-first parents over the edges held, from `root` (which maps to
  // itself), over its whole part or until `stop` is reached; empty if
  // `root` has no edge held.
  std::unordered_map<ImageId, ImageId> HeldParents(
      ImageId root, ImageId stop = kInvalidImageId) const;
  // The images of a shortest path from `a` to `b` over the edges held;
  // empty if there is none.
  std::vector<ImageId> HeldPath(ImageId a, ImageId b) const;
  // Whether the near misses and peers between the two parts bridge k joins
  // outvote it (SkeletonOptions::near_miss_vote, peer_vote_size); `worst`
  // gets the largest rotation error of a cycle it closes with one of them
  // (-1: none).
  bool Outvoted(size_t k, double* worst);
  // Up to SkeletonOptions::peer_vote_size of the heaviest bridges other
  // than k between the parts `part1` and `part2` (held_communities_ roots)
  // that are neither rejected nor taken.
  std::vector<size_t> Peers(size_t k, size_t part1, size_t part2);
  // Whether bridge k may be taken: its score reaches
  // SkeletonOptions::ThresholdFor(role, tree_) and the cycle it closes with
  // the skeleton, if any, is rotation consistent. Records a rejection with
  // `role`. A redundant bridge that would need a new score once the
  // redundancy budget is spent is refused without being scored or recorded.
  bool Admit(size_t k, BridgeRole role);
  // Whether a bridge between parts held apart is put to a vote
  // (SkeletonOptions::near_miss_vote, peer_vote_size).
  bool VoteOn() const {
    return (options_.near_miss_vote || options_.peer_vote_size > 0) &&
           options_.max_cycle_rotation_deg > 0 && scorer_ != nullptr;
  }
  // New verifications the first tree may still ask for
  // (SkeletonOptions::first_tree_budget_trees).
  size_t FirstTreeBudgetLeft() const {
    if (first_tree_budget_ == SIZE_MAX || at_fallback_) return SIZE_MAX;
    return skeleton_.num_verified >= first_tree_budget_
               ? 0
               : first_tree_budget_ - skeleton_.num_verified;
  }
  // New verifications the redundant bridges may still ask for.
  size_t RedundantBudgetLeft() const {
    if (redundant_budget_ == SIZE_MAX) return SIZE_MAX;
    const size_t spent =
        skeleton_.num_verified - verified_after_first_tree_;
    return spent >= redundant_budget_ ? 0 : redundant_budget_ - spent;
  }

  const SkeletonOptions& options_;
  const size_t m_;
  BridgeScorer* scorer_;
  Skeleton skeleton_;
  std::vector<Bridge> bridges_;
  std::vector<CommunityPair> kappas_;
  std::unordered_map<CommunityPair, uint32_t, CommunityPairHash> kappa_ids_;
  std::unique_ptr<ScoreCache> cache_;
  std::vector<char> used_;           // U: community pairs of the skeleton.
  std::vector<char> rejected_seen_;  // Recorded once.
  std::vector<char> in_skeleton_;
  // Image graph of the communities' top-k edges and the bridges taken, and
  // the communities it joins.
  std::unordered_map<ImageId, std::vector<ImageId>> held_;
  UnionFind held_communities_;
  // Rotation error of the cycle each bridge closed when admitted (-1: none).
  std::vector<double> cycle_error_;
  // Bridges rejected for their score alone, scoring in
  // [fallback_threshold, verify_threshold) (SkeletonOptions::
  // near_miss_vote), in the order they were met.
  std::vector<size_t> near_misses_;
  // Bridges the vote refused (the fallback takes them only as a last
  // resort).
  std::vector<char> outvoted_;
  // Each community's bridges, in weight order (SkeletonOptions::
  // peer_vote_size).
  std::vector<std::vector<size_t>> community_bridges_;
  // The tree PackTrees is packing (0-based).
  int tree_ = 0;
  // Pairs verified when the first tree was done, and how many more the
  // redundant bridges may have verified (SkeletonOptions::
  // redundant_budget_trees); unlimited until the first tree is done.
  size_t verified_after_first_tree_ = 0;
  size_t redundant_budget_ = SIZE_MAX;
  // Verifications the first tree may ask for (SIZE_MAX: no budget), and
  // whether it has spent them and goes on at the fallback threshold.
  size_t first_tree_budget_ = SIZE_MAX;
  bool at_fallback_ = false;
};

std::unordered_map<ImageId, ImageId> SkeletonBuilder::HeldParents(
    ImageId root, ImageId stop) const {
  if (!held_.count(root)) return {};
  std::unordered_map<ImageId, ImageId> parent{{root, root}};
  std::queue<ImageId> queue;
  queue.push(root);
  while (!queue.empty() && !parent.count(stop)) {
    const ImageId v = queue.front();
    queue.pop();
    for (const ImageId w : held_.at(v)) {
      if (parent.emplace(w, v).second) queue.push(w);
    }
  }
  return parent;
}

// The path from `root` to `target` along breadth-first `parent`s from
// `root`, as images from `root` on; empty if `target` was not reached.
std::vector<ImageId> PathFromRoot(
    const std::unordered_map<ImageId, ImageId>& parent, ImageId root,
    ImageId target) {
  if (!parent.count(target)) return {};
  std::vector<ImageId> path{target};
  while (path.back() != root) path.push_back(parent.at(path.back()));
  std::reverse(path.begin(), path.end());
  return path;
}

std::vector<ImageId> SkeletonBuilder::HeldPath(ImageId a, ImageId b) const {
  if (!held_.count(b)) return {};
  return PathFromRoot(HeldParents(a, b), a, b);
}

std::vector<size_t> SkeletonBuilder::Peers(size_t k, size_t part1,
                                           size_t part2) {
  const size_t want = static_cast<size_t>(options_.peer_vote_size);
  // A bridge among the few strongest pairs of both its images (a rank
  // tier), or scored as confidently as a redundant one must be, is not put
  // to its peers.
  const Bridge& b = bridges_[k];
  if (want == 0 || part1 == part2 ||
      (options_.rank_tiers > 0 &&
       b.rank <= static_cast<uint32_t>(options_.rank_tiers)) ||
      (cache_->Has(k) && cache_->Get(k) >= options_.redundant_threshold)) {
    return {};
  }
  // The bridges of the smaller part's communities that end in the other.
  std::vector<CommunityId> members1;
  std::vector<CommunityId> members2;
  for (CommunityId c = 0; c < m_; ++c) {
    const size_t root = held_communities_.Find(c);
    if (root == part1) members1.push_back(c);
    if (root == part2) members2.push_back(c);
  }
  const bool first_smaller = members1.size() <= members2.size();
  const std::vector<CommunityId>& smaller =
      first_smaller ? members1 : members2;
  const size_t other = first_smaller ? part2 : part1;
  std::vector<size_t> peers;
  for (const CommunityId c : smaller) {
    for (const size_t j : community_bridges_[c]) {
      if (j == k || rejected_seen_[j] || in_skeleton_[j] || outvoted_[j]) {
        continue;
      }
      const Bridge& n = bridges_[j];
      const CommunityId far = n.c1 == c ? n.c2 : n.c1;
      if (held_communities_.Find(far) == other) peers.push_back(j);
    }
  }
  // The heaviest (bridges_ is in weight order).
  const size_t keep = std::min(want, peers.size());
  std::partial_sort(peers.begin(), peers.begin() + keep, peers.end());
  peers.resize(keep);
  return peers;
}

bool SkeletonBuilder::Outvoted(size_t k, double* worst) {
  *worst = -1.0;
  const Bridge& b = bridges_[k];
  // Near misses whose parts have joined can never vote again.
  near_misses_.erase(
      std::remove_if(near_misses_.begin(), near_misses_.end(),
                     [&](size_t j) {
                       return held_communities_.Connected(bridges_[j].c1,
                                                          bridges_[j].c2);
                     }),
      near_misses_.end());
  // Those between the same two parts, as (near miss, its image on
  // image_id1's side, its image on image_id2's side); heaviest first.
  struct Oriented {
    size_t j;
    ImageId x;
    ImageId y;
  };
  std::vector<Oriented> between;
  uint64_t undecided = 0;
  const size_t part1 = held_communities_.Find(b.c1);
  const size_t part2 = held_communities_.Find(b.c2);
  // Adds bridge j if it joins the same two parts; returns whether it does.
  auto add_if_between = [&](size_t j) {
    const Bridge& n = bridges_[j];
    const size_t n1 = held_communities_.Find(n.c1);
    const size_t n2 = held_communities_.Find(n.c2);
    if (n1 == part1 && n2 == part2) {
      between.push_back({j, n.pair.image_id1, n.pair.image_id2});
    } else if (n1 == part2 && n2 == part1) {
      between.push_back({j, n.pair.image_id2, n.pair.image_id1});
    } else {
      return false;
    }
    undecided += n.weight;
    return true;
  };
  if (options_.near_miss_vote) {
    for (const size_t j : near_misses_) {
      if (j != k) add_if_between(j);
    }
  }
  for (const size_t j : Peers(k, part1, part2)) add_if_between(j);
  // Nothing to decide if the voters together cannot outweigh the bridge.
  if (between.empty() || b.weight >= undecided) return false;
  std::stable_sort(between.begin(), between.end(),
                   [&](const Oriented& u, const Oriented& v) {
                     return bridges_[u.j].weight > bridges_[v.j].weight;
                   });
  const std::unordered_map<ImageId, ImageId> from1 =
      HeldParents(b.pair.image_id1);
  const std::unordered_map<ImageId, ImageId> from2 =
      HeldParents(b.pair.image_id2);
  uint64_t support = b.weight;
  uint64_t against = 0;
  for (const Oriented& o : between) {
    // Stop once the voters left cannot change the outcome.
    if (against > support + undecided || support >= against + undecided) {
      break;
    }
    const uint32_t weight = bridges_[o.j].weight;
    undecided -= weight;
    // The cycle image_id1 .. x, y .. image_id2, closed by the bridge.
    std::vector<ImageId> cycle = PathFromRoot(from1, b.pair.image_id1, o.x);
    const std::vector<ImageId> back =
        PathFromRoot(from2, b.pair.image_id2, o.y);
    if (cycle.empty() || back.empty()) continue;
    cycle.insert(cycle.end(), back.rbegin(), back.rend());
    const double error = scorer_->CycleRotationErrorDeg(cycle);
    if (error < 0) continue;
    if (error > options_.max_cycle_rotation_deg) {
      against += weight;
      *worst = std::max(*worst, error);
    } else {
      support += weight;
    }
  }
  return against > support;
}

bool SkeletonBuilder::Admit(size_t k, BridgeRole role) {
  if (rejected_seen_[k]) return false;
  // A bridge past its verification budget is not scored (and not
  // rejected: it is simply not taken). Redundant bridges share one budget,
  // the first tree has its own until it goes on at the fallback threshold
  // (SkeletonOptions::first_tree_budget_trees), and fallback bridges have
  // none.
  const bool redundant = !(role == BridgeRole::kTree && tree_ == 0);
  const size_t left = role == BridgeRole::kFallback ? SIZE_MAX
                      : redundant                   ? RedundantBudgetLeft()
                                                    : FirstTreeBudgetLeft();
  if (!cache_->Has(k) && left == 0) return false;
  // The cycle first: it costs two breadth-first searches' worth of work
  // and the poses of the pairs on it, where a score can cost a network
  // evaluation; a bridge its cycle rejects is never scored.
  if (options_.max_cycle_rotation_deg > 0 && scorer_ != nullptr) {
    const ImagePair& p = bridges_[k].pair;
    // Bridges taken so far join communities as the held graph joins
    // images (each community is connected by its top-k edges): no search
    // where they are apart.
    const std::vector<ImageId> cycle =
        held_communities_.Connected(bridges_[k].c1, bridges_[k].c2)
            ? HeldPath(p.image_id1, p.image_id2)
            : std::vector<ImageId>();
    if (!cycle.empty()) {
      // The path a..b closes through the bridge b-a.
      const double error = scorer_->CycleRotationErrorDeg(cycle);
      cycle_error_[k] = error;
      if (error > options_.max_cycle_rotation_deg) {
        Reject(k, cache_->Has(k) ? cache_->Get(k) : kNotScored, role, error);
        return false;
      }
    }
  }
  const double score = cache_->Get(k);
  if (score < options_.ThresholdFor(role, tree_)) {
    if (score >= options_.fallback_threshold &&
        score < options_.verify_threshold && cycle_error_[k] < 0) {
      near_misses_.push_back(k);
    }
    Reject(k, score, role, cycle_error_[k]);
    return false;
  }
  // A bridge between parts held apart: its near misses and peers may
  // outvote it.
  double worst = -1.0;
  if (VoteOn() &&
      !held_communities_.Connected(bridges_[k].c1, bridges_[k].c2) &&
      Outvoted(k, &worst)) {
    outvoted_[k] = 1;
    ++skeleton_.num_outvoted;
    Reject(k, score, role, worst);
    skeleton_.rejected.back().outvoted = true;
    return false;
  }
  return true;
}

std::vector<size_t> SkeletonBuilder::TreeOrder() const {
  std::vector<size_t> order(bridges_.size());
  for (size_t k = 0; k < bridges_.size(); ++k) order[k] = k;
  if (options_.rank_tiers > 0) {
    const uint32_t last = static_cast<uint32_t>(options_.rank_tiers) + 1;
    std::stable_sort(order.begin(), order.end(), [&](size_t x, size_t y) {
      return std::min(bridges_[x].rank, last) <
             std::min(bridges_[y].rank, last);
    });
  }
  return order;
}

// Verifications worth `trees` spanning trees of `tree_edges` edges each
// (SIZE_MAX past what size_t holds).
size_t TreesWorth(double trees, size_t tree_edges) {
  const double n = std::ceil(trees * static_cast<double>(tree_edges));
  return n >= static_cast<double>(SIZE_MAX) ? SIZE_MAX
                                            : static_cast<size_t>(n);
}

void SkeletonBuilder::FillSpeculativeBatch(
    const std::vector<size_t>& candidates, size_t i, UnionFind* uf,
    size_t want) {
  std::vector<size_t> todo;
  const size_t end = std::min(candidates.size(), i + kMaxLookahead);
  for (size_t q = i; q < end && todo.size() < want; ++q) {
    const size_t k = candidates[q];
    const Bridge& c = bridges_[k];
    if (used_[c.kappa] || rejected_seen_[k] || cache_->Has(k) ||
        uf->Connected(c.c1, c.c2)) {
      continue;
    }
    todo.push_back(k);
  }
  cache_->Fill(todo);
}

size_t SkeletonBuilder::GoOnAtFallback(UnionFind* uf, size_t tree_size,
                                       size_t max_tree_edges) {
  at_fallback_ = true;
  const size_t joined = JoinThroughNearMisses(uf, /*last_resort=*/false);
  HISFM_LOG_INFO(
      "first tree: verification budget of {} spent with {} of {} bridges; "
      "{} near misses join parts, the rest goes on at the fallback "
      "threshold {}",
      first_tree_budget_, tree_size, max_tree_edges, joined,
      options_.fallback_threshold);
  return joined;
}

bool SkeletonBuilder::PackTrees() {
  // A tree can hold at most m - c edges, c = components of the community
  // graph (a forest when the view graph is disconnected).
  UnionFind all(m_);
  size_t num_components = m_;
  for (const Bridge& b : bridges_) num_components -= all.Union(b.c1, b.c2);
  const size_t max_tree_edges = m_ - num_components;
  const bool budgeted = scorer_ != nullptr && !scorer_->IsFree();
  // Without a fallback to join what the tree leaves apart, no budget.
  if (budgeted && options_.first_tree_budget_trees > 0 &&
      options_.fallback_threshold < options_.verify_threshold) {
    first_tree_budget_ =
        TreesWorth(options_.first_tree_budget_trees, max_tree_edges);
  }
  const size_t batch = std::max<size_t>(
      1, std::min<size_t>(options_.max_verify_batch_size,
                          scorer_ ? scorer_->PreferredBatchSize() : 1));
  // Candidates of the trees: bridges not rejected and not on a used pair.
  std::vector<size_t> candidates = TreeOrder();
  bool all_trees_span = max_tree_edges > 0;
  // Rejections met since the last bridge taken: sizes speculative batches.
  size_t rejection_run = 0;
  for (int t = 0; t < skeleton_.num_trees && max_tree_edges > 0; ++t) {
    tree_ = t;
    UnionFind uf(m_);
    std::vector<uint32_t> tree_pairs;
    size_t tree_size = 0;
    for (size_t i = 0; i < candidates.size() && tree_size < max_tree_edges;
         ++i) {
      const size_t k = candidates[i];
      const Bridge& b = bridges_[k];
      if (used_[b.kappa] || rejected_seen_[k] || uf.Connected(b.c1, b.c2)) {
        continue;
      }
      if (t == 0 && !cache_->Has(k) && FirstTreeBudgetLeft() == 0) {
        tree_size += GoOnAtFallback(&uf, tree_size, max_tree_edges);
        rejection_run = 0;  // lazy again at the fallback threshold
        if (tree_size >= max_tree_edges || uf.Connected(b.c1, b.c2)) continue;
      }
      if (!cache_->Has(k) && batch > 1 && rejection_run > 0) {
        // Later trees: no more than the redundancy budget has left (none
        // once it is spent; Admit then refuses the unscored bridge).
        FillSpeculativeBatch(
            candidates, i, &uf,
            std::min({batch, rejection_run + 1,
                      t == 0 ? FirstTreeBudgetLeft()
                             : RedundantBudgetLeft()}));
      }
      const BridgeRole role =
          t == 0 && at_fallback_ ? BridgeRole::kFallback : BridgeRole::kTree;
      if (!Admit(k, role)) {
        ++rejection_run;
        continue;
      }
      rejection_run = 0;
      uf.Union(b.c1, b.c2);
      tree_pairs.push_back(b.kappa);
      ++tree_size;
      Take(k, cache_->Get(k), role, role == BridgeRole::kTree ? t : -1);
    }
    all_trees_span &= tree_size == max_tree_edges;
    if (t == 0) skeleton_.num_verified_first_tree = skeleton_.num_verified;
    if (t == 0 && budgeted) {
      verified_after_first_tree_ = skeleton_.num_verified;
      redundant_budget_ = TreesWorth(
          options_.redundant_budget_trees * std::max(1, skeleton_.num_trees - 1),
          max_tree_edges);
    }
    for (uint32_t kappa : tree_pairs) used_[kappa] = 1;
    // Later trees never take a rejected bridge or one of a used pair.
    candidates.erase(
        std::remove_if(candidates.begin(), candidates.end(),
                       [&](size_t k) {
                         return rejected_seen_[k] || used_[bridges_[k].kappa];
                       }),
        candidates.end());
  }
  // Bridges admitted from here on are not the first tree's.
  tree_ = -1;
  return all_trees_span;
}

void SkeletonBuilder::RestoreConnectivity() {
  RestoreConnectivityAcrossCuts(
      bridges_, m_, skeleton_.num_trees, kappas_, options_, cache_.get(),
      &used_, [&](size_t k, BridgeRole role) { return Admit(k, role); },
      [&](size_t k) {
        Take(k, cache_->Get(k), BridgeRole::kConnectivity, -1);
      });
}

void SkeletonBuilder::AddBackupBridges() {
  if (options_.num_backup_bridges <= 0) return;
  // Backups still wanted per community pair; -1: not a weak link.
  std::vector<int> wanted(kappas_.size(), -1);
  size_t num_weak = 0;
  for (const BridgeRecord& r : skeleton_.bridges) {
    if (static_cast<int>(r.weight) < options_.weak_link_max_inliers) {
      const uint32_t kappa =
          kappa_ids_.at(MakeCommunityPair(r.community1, r.community2));
      if (wanted[kappa] < 0) {
        wanted[kappa] = options_.num_backup_bridges;
        ++num_weak;
      }
    }
  }
  for (size_t k = 0; k < bridges_.size() && num_weak > 0; ++k) {
    const Bridge& b = bridges_[k];
    if (wanted[b.kappa] <= 0 || in_skeleton_[k] || rejected_seen_[k]) {
      continue;
    }
    if (!Admit(k, BridgeRole::kBackup)) continue;
    Take(k, cache_->Get(k), BridgeRole::kBackup, -1);
    if (--wanted[b.kappa] == 0) --num_weak;
  }
}

void SkeletonBuilder::AddTopWeightBridges() {
  int num_top = 0;
  for (size_t k = 0; k < bridges_.size(); ++k) {
    if (num_top >= options_.num_top_bridges) break;
    const Bridge& b = bridges_[k];
    if (in_skeleton_[k] || used_[b.kappa] || rejected_seen_[k]) continue;
    if (!Admit(k, BridgeRole::kTopWeight)) continue;
    used_[b.kappa] = 1;
    Take(k, cache_->Get(k), BridgeRole::kTopWeight, -1);
    ++num_top;
  }
}

size_t SkeletonBuilder::JoinThroughNearMisses(UnionFind* uf,
                                              bool last_resort) {
  // Bridges scored at least fallback_threshold but not taken (near misses
  // scored below verify_threshold, and any the vote refused), best first
  // (ties: heavier first, then Kruskal's order).
  std::vector<size_t> scored;
  for (size_t k = 0; k < bridges_.size(); ++k) {
    if (!in_skeleton_[k] && cache_->Has(k) &&
        cache_->Get(k) >= options_.fallback_threshold &&
        !uf->Connected(bridges_[k].c1, bridges_[k].c2)) {
      scored.push_back(k);
    }
  }
  std::stable_sort(scored.begin(), scored.end(), [&](size_t a, size_t b) {
    return cache_->Get(a) > cache_->Get(b);
  });
  size_t joined = 0;
  auto take = [&](size_t k) {
    uf->Union(bridges_[k].c1, bridges_[k].c2);
    used_[bridges_[k].kappa] = 1;
    Take(k, cache_->Get(k), BridgeRole::kFallback, -1);
    ++joined;
  };
  for (const size_t k : scored) {
    const Bridge& b = bridges_[k];
    if (uf->Connected(b.c1, b.c2) || outvoted_[k]) continue;
    double worst = -1.0;
    if (VoteOn() && Outvoted(k, &worst)) {
      outvoted_[k] = 1;
      ++skeleton_.num_outvoted;
      continue;
    }
    take(k);
  }
  // Where the vote refused every candidate between two parts (the voters
  // disagree among themselves, or failed verification since), the
  // best-scoring one still joins them: one model rather than pieces.
  if (last_resort) {
    for (const size_t k : scored) {
      if (!uf->Connected(bridges_[k].c1, bridges_[k].c2)) take(k);
    }
  }
  return joined;
}

void SkeletonBuilder::AddFallbackBridges() {
  // Without a fallback, only bridges that passed tau and were refused by
  // the vote can be candidates (their voters may have failed verification
  // since): they still join parts left apart, as a last resort.
  if (options_.fallback_threshold >= options_.verify_threshold &&
      skeleton_.num_outvoted == 0) {
    return;
  }
  // The parts the bridges taken so far hold together (Take unions each).
  UnionFind uf = held_communities_;
  JoinThroughNearMisses(&uf, /*last_resort=*/true);
}

Skeleton SkeletonBuilder::Finish(const ViewGraph& graph,
                                 const Communities& communities) {
  std::set<ImageId> skeletal;
  for (const BridgeRecord& r : skeleton_.bridges) {
    skeletal.insert(r.pair.image_id1);
    skeletal.insert(r.pair.image_id2);
  }
  skeleton_.intra_edges = ConnectSkeletalImages(
      graph, communities, skeletal,
      options_.intra_consistent_weights ? scorer_ : nullptr);
  for (const ViewGraphEdge& e : skeleton_.intra_edges) {
    skeletal.insert(e.pair.image_id1);
    skeletal.insert(e.pair.image_id2);
  }
  skeleton_.images.assign(skeletal.begin(), skeletal.end());
  return std::move(skeleton_);
}

}  // namespace

Skeleton BuildSkeleton(const ViewGraph& graph, const Communities& communities,
                       BridgeScorer* scorer, const SkeletonOptions& options) {
  options.Check();
  const Timer timer;
  SkeletonBuilder builder(graph, communities, scorer, options);
  const bool all_trees_span = builder.PackTrees();
  // K edge-disjoint spanning forests are K-edge-connected in every
  // component: the repair is needed only when a tree fell short.
  if (options.restore_connectivity && options.NumTreesFor(graph.NumImages()) > 1 &&
      !all_trees_span) {
    builder.RestoreConnectivity();
  }
  builder.AddBackupBridges();
  builder.AddTopWeightBridges();
  if (!all_trees_span) builder.AddFallbackBridges();
  HISFM_LOG_DEBUG("skeleton built ({:.2f} s)", timer.ElapsedSeconds());
  return builder.Finish(graph, communities);
}

}  // namespace hisfm
