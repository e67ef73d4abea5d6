#include "hisfm/graph/skeleton.h"

#include <algorithm>
#include <cmath>
#include <set>
#include <unordered_map>
#include <unordered_set>

#include "hisfm/graph/min_cut.h"
#include "hisfm/graph/union_find.h"
#include "hisfm/util/error.h"
#include "hisfm/util/logging.h"

namespace hisfm {

void SkeletonOptions::Check() const {
  HISFM_CHECK_OPTION(num_trees >= 0);
  HISFM_CHECK_OPTION(images_per_tree >= 1);
  HISFM_CHECK_OPTION(verify_threshold >= 0.0 && verify_threshold <= 1.0);
  HISFM_CHECK_OPTION(num_top_bridges >= 0);
  HISFM_CHECK_OPTION(num_backup_bridges >= 0);
  HISFM_CHECK_OPTION(weak_link_max_inliers >= 0);
  HISFM_CHECK_OPTION(max_verify_batch_size >= 1);
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
using CommunityPairSet = std::unordered_set<CommunityPair, CommunityPairHash>;

struct Bridge {
  ImagePair pair;
  CommunityId c1;
  CommunityId c2;
  uint32_t weight;
};

// Lazily scores bridges, each at most once, counting work.
class ScoreCache {
 public:
  ScoreCache(BridgeScorer* scorer, size_t batch_size, Skeleton* skeleton)
      : scorer_(scorer), batch_size_(batch_size), skeleton_(skeleton) {}

  bool Has(const ImagePair& p) const { return scores_.count(p) > 0; }

  // Scores `pairs` that are not cached yet, in one call.
  void Fill(const std::vector<ImagePair>& pairs) {
    std::vector<ImagePair> todo;
    for (const ImagePair& p : pairs) {
      if (!Has(p)) todo.push_back(p);
    }
    if (todo.empty()) return;
    std::vector<double> s =
        scorer_ ? scorer_->Score(todo) : std::vector<double>(todo.size(), 1.0);
    ThrowUnless(s.size() == todo.size(),
                "verifier returned a wrong number of scores");
    for (size_t i = 0; i < todo.size(); ++i) {
      ThrowUnless(std::isfinite(s[i]), "verifier returned a non-finite score");
      scores_[todo[i]] = std::clamp(s[i], 0.0, 1.0);
    }
    skeleton_->num_verified += todo.size();
    ++skeleton_->num_scorer_calls;
  }

  double Get(const ImagePair& p) {
    if (!Has(p)) Fill({p});
    return scores_.at(p);
  }

  size_t batch_size() const { return batch_size_; }

 private:
  BridgeScorer* scorer_;
  size_t batch_size_;
  Skeleton* skeleton_;
  std::unordered_map<ImagePair, double, ImagePairHash> scores_;
};

BridgeRecord MakeRecord(const Bridge& b, double score, bool accepted,
                        BridgeRole role, int tree) {
  BridgeRecord r;
  r.pair = b.pair;
  r.community1 = b.c1;
  r.community2 = b.c2;
  r.weight = b.weight;
  r.score = score;
  r.accepted = accepted;
  r.role = role;
  r.tree = tree;
  return r;
}

// Joins the skeletal images of each community: the maximum spanning tree of
// the community's induced subgraph, pruned of non-skeletal leaves, i.e. the
// smallest subtree that connects them. A community with no skeletal image
// keeps its whole maximum spanning tree.
std::vector<ViewGraphEdge> ConnectSkeletalImages(
    const ViewGraph& graph, const Communities& communities,
    const std::set<ImageId>& skeletal) {
  std::vector<ViewGraphEdge> out;
  std::vector<std::vector<size_t>> community_edges(
      communities.NumCommunities());
  for (size_t e = 0; e < graph.NumEdges(); ++e) {
    const ImagePair& p = graph.Edges()[e].pair;
    const CommunityId c = communities.Of(p.image_id1);
    if (c == communities.Of(p.image_id2)) community_edges[c].push_back(e);
  }
  for (CommunityId c = 0; c < communities.NumCommunities(); ++c) {
    const std::vector<ImageId>& members = communities.members[c];
    size_t num_skeletal = 0;
    for (ImageId id : members) num_skeletal += skeletal.count(id);
    // A community without any bridge (alone in its component, or cut off by
    // rejected bridges) becomes a scaffold of its own: keep its whole tree.
    const bool keep_all = num_skeletal == 0;
    if (members.size() < 2 || num_skeletal == 1) continue;
    auto is_terminal = [&](ImageId id) {
      return keep_all || skeletal.count(id) > 0;
    };
    std::unordered_map<ImageId, size_t> local;
    for (size_t i = 0; i < members.size(); ++i) local[members[i]] = i;
    std::vector<size_t>& edges = community_edges[c];
    std::sort(edges.begin(), edges.end(), [&](size_t a, size_t b) {
      const auto& ea = graph.Edges()[a];
      const auto& eb = graph.Edges()[b];
      return ea.weight > eb.weight || (ea.weight == eb.weight && a < b);
    });
    UnionFind uf(members.size());
    std::vector<std::vector<std::pair<size_t, size_t>>> tree(members.size());
    for (size_t e : edges) {
      const ImagePair& p = graph.Edges()[e].pair;
      const size_t a = local[p.image_id1];
      const size_t b = local[p.image_id2];
      if (uf.Union(a, b)) {
        tree[a].push_back({b, e});
        tree[b].push_back({a, e});
      }
    }
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
template <typename RejectFn>
void RestoreConnectivity(const std::vector<Bridge>& bridges, size_t m, int K,
                         const SkeletonOptions& options, ScoreCache* cache,
                         CommunityPairSet* used,
                         std::set<ImagePair>* in_skeleton, Skeleton* skeleton,
                         RejectFn&& reject) {
  UnionFind all(m);
  for (const Bridge& b : bridges) all.Union(b.c1, b.c2);
  std::map<size_t, std::vector<CommunityId>> components;
  for (CommunityId c = 0; c < m; ++c) components[all.Find(c)].push_back(c);
  for (const auto& [root, members] : components) {
    if (members.size() < 2) continue;
    std::unordered_map<CommunityId, size_t> local;
    for (size_t i = 0; i < members.size(); ++i) local[members[i]] = i;
    std::set<ImagePair> dead;  // Rejected while repairing this component.
    for (size_t iteration = 0; iteration < K * members.size(); ++iteration) {
      std::vector<std::pair<size_t, size_t>> edges;
      for (const CommunityPair& kappa : *used) {
        if (local.count(kappa.first)) {
          edges.push_back({local[kappa.first], local[kappa.second]});
        }
      }
      const MinCut cut = GlobalMinCut(members.size(), edges);
      if (cut.value >= static_cast<size_t>(K)) break;
      std::vector<bool> in_side(members.size(), false);
      for (size_t v : cut.side) in_side[v] = true;
      bool added = false;
      for (const Bridge& b : bridges) {
        if (!local.count(b.c1)) continue;
        const CommunityPair kappa = MakeCommunityPair(b.c1, b.c2);
        if (in_side[local[b.c1]] == in_side[local[b.c2]] ||
            used->count(kappa) || dead.count(b.pair)) {
          continue;
        }
        const double score = cache->Get(b.pair);
        if (score < options.verify_threshold) {
          reject(b, score, BridgeRole::kConnectivity);
          dead.insert(b.pair);
          continue;
        }
        used->insert(kappa);
        in_skeleton->insert(b.pair);
        skeleton->bridges.push_back(
            MakeRecord(b, score, true, BridgeRole::kConnectivity, -1));
        added = true;
        break;
      }
      if (!added) break;
    }
  }
}

}  // namespace

Skeleton BuildSkeleton(const ViewGraph& graph, const Communities& communities,
                       BridgeScorer* scorer, const SkeletonOptions& options) {
  options.Check();
  Skeleton skeleton;
  skeleton.num_trees = options.NumTreesFor(graph.NumImages());
  const size_t m = communities.NumCommunities();

  std::vector<Bridge> bridges;
  for (const ViewGraphEdge& e : graph.Edges()) {
    const CommunityId a = communities.Of(e.pair.image_id1);
    const CommunityId b = communities.Of(e.pair.image_id2);
    if (a != b) bridges.push_back({e.pair, a, b, e.weight});
  }
  std::stable_sort(bridges.begin(), bridges.end(),
                   [](const Bridge& x, const Bridge& y) {
                     return x.weight > y.weight;
                   });
  skeleton.num_candidate_bridges = bridges.size();

  // A tree can hold at most m - c edges, c = components of the community
  // graph (a forest when the view graph is disconnected).
  UnionFind all(m);
  size_t num_components = m;
  for (const Bridge& b : bridges) num_components -= all.Union(b.c1, b.c2);
  const size_t max_tree_edges = m - num_components;

  const size_t batch = std::max<size_t>(
      1, std::min<size_t>(options.max_verify_batch_size,
                          scorer ? scorer->PreferredBatchSize() : 1));
  ScoreCache cache(scorer, batch, &skeleton);
  CommunityPairSet used;  // U: community pairs of earlier trees.
  std::set<ImagePair> rejected_seen;  // Rejections are recorded once.
  std::set<ImagePair> in_skeleton;

  auto reject = [&](const Bridge& b, double score, BridgeRole role) {
    if (rejected_seen.insert(b.pair).second) {
      skeleton.rejected.push_back(MakeRecord(b, score, false, role, -1));
    }
  };

  for (int t = 0; t < skeleton.num_trees && max_tree_edges > 0; ++t) {
    UnionFind uf(m);
    std::vector<CommunityPair> tree_pairs;
    size_t tree_size = 0;
    for (size_t k = 0; k < bridges.size() && tree_size < max_tree_edges;
         ++k) {
      const Bridge& b = bridges[k];
      const CommunityPair kappa = MakeCommunityPair(b.c1, b.c2);
      if (used.count(kappa) || uf.Connected(b.c1, b.c2)) continue;
      if (!cache.Has(b.pair) && cache.batch_size() > 1) {
        // Speculative batch: the next bridges Kruskal would take if every
        // earlier one passed. Those remain valid candidates if one fails.
        UnionFind sim = uf;
        CommunityPairSet sim_pairs;
        std::vector<ImagePair> todo;
        for (size_t q = k; q < bridges.size() && todo.size() < cache.batch_size();
             ++q) {
          const Bridge& c = bridges[q];
          const CommunityPair kc = MakeCommunityPair(c.c1, c.c2);
          if (used.count(kc) || sim_pairs.count(kc) || !sim.Union(c.c1, c.c2))
            continue;
          sim_pairs.insert(kc);
          todo.push_back(c.pair);
        }
        cache.Fill(todo);
      }
      const double score = cache.Get(b.pair);
      if (score < options.verify_threshold) {
        reject(b, score, BridgeRole::kTree);
        continue;
      }
      uf.Union(b.c1, b.c2);
      tree_pairs.push_back(kappa);
      ++tree_size;
      in_skeleton.insert(b.pair);
      skeleton.bridges.push_back(
          MakeRecord(b, score, true, BridgeRole::kTree, t));
    }
    used.insert(tree_pairs.begin(), tree_pairs.end());
  }

  if (options.restore_connectivity && skeleton.num_trees > 1) {
    RestoreConnectivity(bridges, m, skeleton.num_trees, options, &cache,
                        &used, &in_skeleton, &skeleton, reject);
  }

  // Backups for weak links: verified parallel bridges between the same
  // communities as a weak tree bridge.
  if (options.num_backup_bridges > 0) {
    std::map<CommunityPair, int> weak;
    for (const BridgeRecord& r : skeleton.bridges) {
      if (static_cast<int>(r.weight) < options.weak_link_max_inliers) {
        weak[MakeCommunityPair(r.community1, r.community2)] = 0;
      }
    }
    for (const Bridge& b : bridges) {
      if (weak.empty()) break;
      auto it = weak.find(MakeCommunityPair(b.c1, b.c2));
      if (it == weak.end() || in_skeleton.count(b.pair)) continue;
      const double score = cache.Get(b.pair);
      if (score < options.verify_threshold) {
        reject(b, score, BridgeRole::kBackup);
        continue;
      }
      in_skeleton.insert(b.pair);
      skeleton.bridges.push_back(
          MakeRecord(b, score, true, BridgeRole::kBackup, -1));
      if (++it->second >= options.num_backup_bridges) weak.erase(it);
    }
  }

  // Extra top-weight bridges on community pairs not used yet.
  int num_top = 0;
  for (const Bridge& b : bridges) {
    if (num_top >= options.num_top_bridges) break;
    const CommunityPair kappa = MakeCommunityPair(b.c1, b.c2);
    if (in_skeleton.count(b.pair) || used.count(kappa)) continue;
    const double score = cache.Get(b.pair);
    if (score < options.verify_threshold) {
      reject(b, score, BridgeRole::kTopWeight);
      continue;
    }
    used.insert(kappa);
    in_skeleton.insert(b.pair);
    skeleton.bridges.push_back(
        MakeRecord(b, score, true, BridgeRole::kTopWeight, -1));
    ++num_top;
  }

  std::set<ImageId> skeletal;
  for (const BridgeRecord& r : skeleton.bridges) {
    skeletal.insert(r.pair.image_id1);
    skeletal.insert(r.pair.image_id2);
  }
  skeleton.intra_edges = ConnectSkeletalImages(graph, communities, skeletal);
  for (const ViewGraphEdge& e : skeleton.intra_edges) {
    skeletal.insert(e.pair.image_id1);
    skeletal.insert(e.pair.image_id2);
  }
  skeleton.images.assign(skeletal.begin(), skeletal.end());
  return skeleton;
}

}  // namespace hisfm
