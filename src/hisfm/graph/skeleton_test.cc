#include "hisfm/graph/skeleton.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <random>
#include <set>

#include "hisfm/graph/hierarchy.h"
#include "hisfm/graph/min_cut.h"
#include "hisfm/graph/union_find.h"
#include "hisfm/util/error.h"

namespace hisfm {
namespace {

// `num_clusters` chains of `cluster_size` images with strong, distinct
// internal weights (top-1 communities are the chains, or parts of them), plus
// random weaker edges between clusters.
ViewGraph ClusteredGraph(int num_clusters, int cluster_size, double density,
                         uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::uniform_int_distribution<uint32_t> weak(15, 150);
  std::vector<ImageId> images;
  std::vector<ViewGraphEdge> edges;
  auto id = [&](int c, int i) { return ImageId(c * cluster_size + i + 1); };
  for (int c = 0; c < num_clusters; ++c) {
    for (int i = 0; i < cluster_size; ++i) {
      images.push_back(id(c, i));
      if (i > 0) edges.push_back({ImagePair(id(c, i - 1), id(c, i)),
                                  uint32_t(1000 + 7 * i + 13 * c)});
    }
  }
  for (int a = 0; a < num_clusters; ++a)
    for (int b = a + 1; b < num_clusters; ++b)
      for (int i = 0; i < cluster_size; ++i)
        for (int j = 0; j < cluster_size; ++j)
          if (u(rng) < density)
            edges.push_back({ImagePair(id(a, i), id(b, j)), weak(rng)});
  return ViewGraph::FromEdges(images, edges);
}

// Records every scored pair; rejects the pairs in `reject`.
class RecordingScorer : public BridgeScorer {
 public:
  std::set<ImagePair> reject;
  std::vector<ImagePair> calls;
  size_t batch = 1;
  std::string Name() const override { return "recording"; }
  size_t PreferredBatchSize() const override { return batch; }
  std::vector<double> Score(const std::vector<ImagePair>& pairs) override {
    std::vector<double> s;
    for (const ImagePair& p : pairs) {
      calls.push_back(p);
      s.push_back(reject.count(p) ? 0.1 : 0.9);
    }
    return s;
  }
};

using CommunityPair = std::pair<CommunityId, CommunityId>;
CommunityPair Kappa(const BridgeRecord& b) {
  return {std::min(b.community1, b.community2),
          std::max(b.community1, b.community2)};
}

// Minimum cut of the community multigraph (GlobalMinCut is checked against
// enumeration in min_cut_test.cc).
size_t MinCutValue(size_t n, const std::vector<CommunityPair>& pairs) {
  std::vector<std::pair<size_t, size_t>> edges(pairs.begin(), pairs.end());
  return GlobalMinCut(n, edges).value;
}

TEST(Skeleton, TreesAreDisjointForestsOverCommunities) {
  for (uint32_t seed = 0; seed < 10; ++seed) {
    const ViewGraph g = ClusteredGraph(8, 5, 0.2, seed);
    const Communities c = ComputeCommunities(g, CommunityOptions());
    SkeletonOptions options;
    options.num_trees = 3;
    options.num_backup_bridges = 0;
    const Skeleton s = BuildSkeleton(g, c, nullptr, options);
    std::map<int, std::vector<CommunityPair>> trees;
    std::map<CommunityPair, int> owner;
    for (const BridgeRecord& b : s.bridges) {
      ASSERT_EQ(b.role, BridgeRole::kTree);
      ASSERT_NE(b.community1, b.community2);
      trees[b.tree].push_back(Kappa(b));
      auto [it, inserted] = owner.emplace(Kappa(b), b.tree);
      EXPECT_TRUE(inserted) << "community pair used by trees " << it->second
                            << " and " << b.tree;
    }
    for (const auto& [t, edges] : trees) {
      UnionFind uf(c.NumCommunities());
      for (const auto& [a, b] : edges) {
        EXPECT_TRUE(uf.Union(a, b)) << "tree " << t << " has a cycle";
      }
    }
  }
}

TEST(Skeleton, KTreesGiveKEdgeConnectivity) {
  for (uint32_t seed = 0; seed < 10; ++seed) {
    // Dense inter-cluster links: the community graph admits 3 disjoint trees.
    const ViewGraph g = ClusteredGraph(7, 4, 0.5, seed);
    const Communities c = ComputeCommunities(g, CommunityOptions());
    ASSERT_LE(c.NumCommunities(), 16u);
    SkeletonOptions options;
    options.num_trees = 3;
    options.num_backup_bridges = 0;
    const Skeleton s = BuildSkeleton(g, c, nullptr, options);
    std::vector<CommunityPair> edges, all_pairs;
    for (const BridgeRecord& b : s.bridges) edges.push_back(Kappa(b));
    for (const ViewGraphEdge& e : g.Edges()) {
      CommunityId a = c.Of(e.pair.image_id1), b = c.Of(e.pair.image_id2);
      if (a != b) all_pairs.push_back({std::min(a, b), std::max(a, b)});
    }
    std::sort(all_pairs.begin(), all_pairs.end());
    all_pairs.erase(std::unique(all_pairs.begin(), all_pairs.end()),
                    all_pairs.end());
    // Necessary condition (Nash-Williams) for 3 disjoint spanning trees on
    // the simple community graph; the generated graphs are dense enough.
    ASSERT_GE(MinCutValue(c.NumCommunities(), all_pairs), 6u);
    EXPECT_GE(MinCutValue(c.NumCommunities(), edges), 3u)
        << "seed " << seed;
    // Without the repair, greedy packing alone may fall short, but each tree
    // stays a forest and the first tree spans.
    options.restore_connectivity = false;
    const Skeleton greedy = BuildSkeleton(g, c, nullptr, options);
    size_t first_tree = 0;
    for (const BridgeRecord& b : greedy.bridges) first_tree += b.tree == 0;
    EXPECT_EQ(first_tree, c.NumCommunities() - 1);
  }
}

TEST(Skeleton, SkeletonIsConnectedInsideEveryCommunity) {
  for (uint32_t seed = 0; seed < 10; ++seed) {
    const ViewGraph g = ClusteredGraph(6, 8, 0.1, seed);
    const Communities c = ComputeCommunities(g, CommunityOptions());
    SkeletonOptions options;
    options.num_trees = 2;
    const Skeleton s = BuildSkeleton(g, c, nullptr, options);
    std::map<ImageId, size_t> local;
    for (size_t i = 0; i < s.images.size(); ++i) local[s.images[i]] = i;
    UnionFind uf(s.images.size());
    for (const ViewGraphEdge& e : s.intra_edges) {
      ASSERT_EQ(c.Of(e.pair.image_id1), c.Of(e.pair.image_id2));
      uf.Union(local.at(e.pair.image_id1), local.at(e.pair.image_id2));
    }
    std::map<CommunityId, std::set<size_t>> roots;
    for (ImageId id : s.images) roots[c.Of(id)].insert(uf.Find(local[id]));
    for (const auto& [community, r] : roots) {
      EXPECT_EQ(r.size(), 1u) << "community " << community << " seed " << seed;
    }
    for (const BridgeRecord& b : s.bridges) {
      EXPECT_TRUE(s.Contains(b.pair.image_id1));
      EXPECT_TRUE(s.Contains(b.pair.image_id2));
    }
  }
}

// Reference Kruskal with verification: the set of bridges passing the union-
// find and diversity tests when they are met, in order.
std::vector<ImagePair> ReferenceScoredBridges(const ViewGraph& g,
                                              const Communities& c, int K,
                                              const std::set<ImagePair>& reject) {
  std::vector<ViewGraphEdge> bridges;
  for (const ViewGraphEdge& e : g.Edges())
    if (c.Of(e.pair.image_id1) != c.Of(e.pair.image_id2)) bridges.push_back(e);
  std::stable_sort(bridges.begin(), bridges.end(),
                   [](const auto& a, const auto& b) { return a.weight > b.weight; });
  std::set<CommunityPair> used;
  std::vector<ImagePair> scored;
  std::set<ImagePair> scored_set;
  for (int t = 0; t < K; ++t) {
    UnionFind uf(c.NumCommunities());
    std::set<CommunityPair> mine;
    for (const auto& e : bridges) {
      CommunityId a = c.Of(e.pair.image_id1), b = c.Of(e.pair.image_id2);
      CommunityPair kappa(std::min(a, b), std::max(a, b));
      if (used.count(kappa) || uf.Connected(a, b)) continue;
      if (scored_set.insert(e.pair).second) scored.push_back(e.pair);
      if (reject.count(e.pair)) continue;
      uf.Union(a, b);
      mine.insert(kappa);
    }
    used.insert(mine.begin(), mine.end());
  }
  return scored;
}

TEST(Skeleton, VerifiesOnlyBridgesKruskalWouldTakeOnceEach) {
  for (uint32_t seed = 0; seed < 10; ++seed) {
    const ViewGraph g = ClusteredGraph(8, 4, 0.3, seed);
    const Communities c = ComputeCommunities(g, CommunityOptions());
    RecordingScorer scorer;
    // Reject every third bridge met.
    std::vector<ImagePair> first = ReferenceScoredBridges(g, c, 2, {});
    for (size_t i = 0; i < first.size(); i += 3) scorer.reject.insert(first[i]);
    SkeletonOptions options;
    options.num_trees = 2;
    options.num_backup_bridges = 0;
    // Algorithm 1 as the paper states it: bridges by weight, no budget for
    // the second tree.
    options.rank_tiers = 0;
    options.redundant_budget_trees = 1e6;
    const Skeleton s = BuildSkeleton(g, c, &scorer, options);
    const std::vector<ImagePair> expected =
        ReferenceScoredBridges(g, c, 2, scorer.reject);
    EXPECT_EQ(scorer.calls, expected) << "seed " << seed;
    EXPECT_EQ(s.num_verified, expected.size());
    EXPECT_LT(s.num_verified, s.num_candidate_bridges);
    for (const BridgeRecord& b : s.bridges) {
      EXPECT_FALSE(scorer.reject.count(b.pair));
    }
    for (const BridgeRecord& b : s.rejected) {
      EXPECT_TRUE(scorer.reject.count(b.pair));
      EXPECT_LT(b.score, options.verify_threshold);
    }
    // A rejected bridge is replaced by the next candidate: trees still span.
    std::map<int, size_t> tree_size;
    for (const BridgeRecord& b : s.bridges) ++tree_size[b.tree];
    EXPECT_EQ(tree_size[0], c.NumCommunities() - 1);
  }
}

TEST(Skeleton, BatchedScoringMakesTheSameDecisions) {
  for (uint32_t seed = 0; seed < 5; ++seed) {
    const ViewGraph g = ClusteredGraph(8, 4, 0.3, seed);
    const Communities c = ComputeCommunities(g, CommunityOptions());
    RecordingScorer lazy, batched;
    std::vector<ImagePair> first = ReferenceScoredBridges(g, c, 2, {});
    for (size_t i = 0; i < first.size(); i += 2) {
      lazy.reject.insert(first[i]);
      batched.reject.insert(first[i]);
    }
    batched.batch = 8;
    SkeletonOptions options;
    options.num_trees = 2;
    options.redundant_budget_trees = 1e6;
    const Skeleton a = BuildSkeleton(g, c, &lazy, options);
    const Skeleton b = BuildSkeleton(g, c, &batched, options);
    EXPECT_EQ(a.Edges(), b.Edges());
    std::set<ImagePair> unique(batched.calls.begin(), batched.calls.end());
    EXPECT_EQ(unique.size(), batched.calls.size()) << "a pair scored twice";
    // Runs of rejections were verified in batches.
    EXPECT_LT(b.num_scorer_calls, b.num_verified);
    EXPECT_EQ(a.num_scorer_calls, a.num_verified);
  }
}

// A scorer that gives every bridge the same score.
class ConstantScorer : public BridgeScorer {
 public:
  explicit ConstantScorer(double score, size_t batch = 1)
      : score_(score), batch_(batch) {}
  size_t num_scored = 0;
  std::string Name() const override { return "constant"; }
  size_t PreferredBatchSize() const override { return batch_; }
  std::vector<double> Score(const std::vector<ImagePair>& pairs) override {
    num_scored += pairs.size();
    return std::vector<double>(pairs.size(), score_);
  }

 private:
  double score_;
  size_t batch_;
};

TEST(Skeleton, RedundantBridgesNeedTheStricterThresholdWithinABudget) {
  for (uint32_t seed = 0; seed < 5; ++seed) {
    const ViewGraph g = ClusteredGraph(8, 4, 0.3, seed);
    const Communities c = ComputeCommunities(g, CommunityOptions());
    const size_t tree_edges = c.NumCommunities() - 1;
    SkeletonOptions options;
    options.num_trees = 3;
    options.num_backup_bridges = 0;
    options.max_cycle_rotation_deg = 0;
    // Every bridge scores 0.7: enough for the first tree (tau = 0.5), not
    // for the redundant ones (0.8). The first tree spans; later trees and
    // the connectivity repair verify at most (K - 1) trees' worth of
    // bridges and take none.
    ConstantScorer middling(0.7);
    const Skeleton s = BuildSkeleton(g, c, &middling, options);
    std::map<int, size_t> tree_size;
    for (const BridgeRecord& b : s.bridges) ++tree_size[b.tree];
    EXPECT_EQ(tree_size[0], tree_edges) << "seed " << seed;
    EXPECT_EQ(s.bridges.size(), tree_edges);
    EXPECT_EQ(s.num_verified, tree_edges + 2 * tree_edges);
    EXPECT_EQ(middling.num_scored, s.num_verified);
    // Speculative batches of a batched scorer stay within the budget too.
    ConstantScorer batched(0.7, 8);
    const Skeleton b = BuildSkeleton(g, c, &batched, options);
    EXPECT_EQ(b.bridges.size(), tree_edges);
    EXPECT_LE(b.num_verified, tree_edges + 2 * tree_edges);
    EXPECT_EQ(batched.num_scored, b.num_verified);
    // Scoring 0.9, the redundant bridges pass; the budget is the same.
    ConstantScorer confident(0.9);
    const Skeleton t = BuildSkeleton(g, c, &confident, options);
    EXPECT_GT(t.bridges.size(), tree_edges);
    EXPECT_LE(t.num_verified, tree_edges + 2 * tree_edges);
    // Without a scorer (nothing to pay for) there is no budget: the later
    // trees take as many bridges as with the budget lifted.
    const Skeleton free_default = BuildSkeleton(g, c, nullptr, options);
    SkeletonOptions unlimited = options;
    unlimited.redundant_budget_trees = 1e6;
    const Skeleton free_unlimited = BuildSkeleton(g, c, nullptr, unlimited);
    EXPECT_EQ(free_default.bridges.size(), free_unlimited.bridges.size());
    EXPECT_GT(free_default.bridges.size(), tree_edges);
  }
  // The threshold is never below tau.
  SkeletonOptions strict;
  strict.verify_threshold = 0.95;
  strict.redundant_threshold = 0.5;
  EXPECT_DOUBLE_EQ(strict.ThresholdFor(BridgeRole::kTree, 1), 0.95);
  EXPECT_DOUBLE_EQ(strict.ThresholdFor(BridgeRole::kTree, 0), 0.95);
  SkeletonOptions options;
  EXPECT_DOUBLE_EQ(options.ThresholdFor(BridgeRole::kTree, 0), 0.5);
  EXPECT_DOUBLE_EQ(options.ThresholdFor(BridgeRole::kTree, 1), 0.8);
  EXPECT_DOUBLE_EQ(options.ThresholdFor(BridgeRole::kConnectivity, -1), 0.8);
  EXPECT_DOUBLE_EQ(options.ThresholdFor(BridgeRole::kBackup, -1), 0.8);
  options.redundant_budget_trees = -1;
  EXPECT_THROW(options.Check(), Error);
  options.redundant_budget_trees = INFINITY;
  EXPECT_THROW(options.Check(), Error);
  options = SkeletonOptions();
  options.redundant_threshold = 1.5;
  EXPECT_THROW(options.Check(), Error);
}

TEST(Skeleton, BatchesStayLazyWhileBridgesPass) {
  for (uint32_t seed = 0; seed < 5; ++seed) {
    const ViewGraph g = ClusteredGraph(8, 4, 0.3, seed);
    const Communities c = ComputeCommunities(g, CommunityOptions());
    RecordingScorer lazy, batched;
    batched.batch = 16;
    SkeletonOptions options;
    options.num_trees = 2;
    const Skeleton a = BuildSkeleton(g, c, &lazy, options);
    const Skeleton b = BuildSkeleton(g, c, &batched, options);
    // Without rejections nothing is verified ahead: the same pairs, in the
    // same order, one per call.
    EXPECT_EQ(batched.calls, lazy.calls);
    EXPECT_EQ(b.num_scorer_calls, b.num_verified);
    EXPECT_EQ(a.Edges(), b.Edges());
  }
}

TEST(Skeleton, AutomaticNumberOfTrees) {
  SkeletonOptions options;
  EXPECT_EQ(options.NumTreesFor(64), 1);
  EXPECT_EQ(options.NumTreesFor(449), 1);
  EXPECT_EQ(options.NumTreesFor(451), 2);
  EXPECT_EQ(options.NumTreesFor(3000), 10);
  options.num_trees = 4;
  EXPECT_EQ(options.NumTreesFor(64), 4);
}

TEST(Skeleton, BackupBridgesForWeakLinks) {
  // Two communities {1,2} and {3,4} joined by weak bridges only.
  const ViewGraph g = ViewGraph::FromEdges(
      {1, 2, 3, 4}, {{ImagePair(1, 2), 500},
                     {ImagePair(3, 4), 500},
                     {ImagePair(1, 3), 40},
                     {ImagePair(2, 4), 30},
                     {ImagePair(2, 3), 20}});
  const Communities c = ComputeCommunities(g, CommunityOptions());
  SkeletonOptions options;
  options.num_backup_bridges = 1;
  options.weak_link_max_inliers = 50;
  const Skeleton s = BuildSkeleton(g, c, nullptr, options);
  ASSERT_EQ(s.bridges.size(), 2u);
  EXPECT_EQ(s.bridges[0].pair, ImagePair(1, 3));
  EXPECT_EQ(s.bridges[1].pair, ImagePair(2, 4));
  EXPECT_EQ(s.bridges[1].role, BridgeRole::kBackup);
}

// (pair, role) of every bridge taken or rejected.
std::set<std::pair<ImagePair, BridgeRole>> Roles(
    const std::vector<BridgeRecord>& records) {
  std::set<std::pair<ImagePair, BridgeRole>> out;
  for (const BridgeRecord& r : records) out.insert({r.pair, r.role});
  return out;
}

// Three communities A = {1, 2}, B = {3, 4}, C = {5, 6} (strong internal
// pairs) and bridges A-B (1,3) 300, A-C (1,5) 200, A-C (2,6) 150,
// B-C (3,5) 100, B-C (4,6) 90.
ViewGraph ThreeCommunities() {
  return ViewGraph::FromEdges(
      {1, 2, 3, 4, 5, 6},
      {{ImagePair(1, 2), 1000}, {ImagePair(3, 4), 1001},
       {ImagePair(5, 6), 1002}, {ImagePair(1, 3), 300},
       {ImagePair(1, 5), 200},  {ImagePair(2, 6), 150},
       {ImagePair(3, 5), 100},  {ImagePair(4, 6), 90}});
}

// One tree, no backup bridges, trees by weight (Algorithm 1's order).
SkeletonOptions OneTreeByWeight() {
  SkeletonOptions options;
  options.num_trees = 1;
  options.num_backup_bridges = 0;
  options.rank_tiers = 0;
  return options;
}

TEST(Skeleton, TopWeightBridgesGoOnCommunityPairsNotUsedYet) {
  const ViewGraph g = ThreeCommunities();
  const Communities c = ComputeCommunities(g, CommunityOptions());
  ASSERT_EQ(c.NumCommunities(), 3u);
  SkeletonOptions options = OneTreeByWeight();
  // Trees by weight (with rank tiers, (2,6), rank 2, would join A-C).
  // One tree: (1,3) and (1,5); no top-weight bridge by default.
  const Skeleton tree_only = BuildSkeleton(g, c, nullptr, options);
  EXPECT_EQ(Roles(tree_only.bridges),
            (std::set<std::pair<ImagePair, BridgeRole>>{
                {ImagePair(1, 3), BridgeRole::kTree},
                {ImagePair(1, 5), BridgeRole::kTree}}));

  // The heaviest bridge on an unused community pair is (3,5), not the
  // heavier (2,6) of the used pair A-C; a second one finds no unused pair.
  for (const int num_top : {1, 2}) {
    options.num_top_bridges = num_top;
    const Skeleton s = BuildSkeleton(g, c, nullptr, options);
    EXPECT_EQ(Roles(s.bridges),
              (std::set<std::pair<ImagePair, BridgeRole>>{
                  {ImagePair(1, 3), BridgeRole::kTree},
                  {ImagePair(1, 5), BridgeRole::kTree},
                  {ImagePair(3, 5), BridgeRole::kTopWeight}}))
        << num_top;
    EXPECT_TRUE(s.Contains(3) && s.Contains(5));
  }

  // Verified: a rejected (3,5) is recorded, and the next bridge of B-C,
  // (4,6), is taken instead.
  RecordingScorer scorer;
  scorer.reject = {ImagePair(3, 5)};
  options.num_top_bridges = 1;
  const Skeleton verified = BuildSkeleton(g, c, &scorer, options);
  EXPECT_EQ(Roles(verified.bridges),
            (std::set<std::pair<ImagePair, BridgeRole>>{
                {ImagePair(1, 3), BridgeRole::kTree},
                {ImagePair(1, 5), BridgeRole::kTree},
                {ImagePair(4, 6), BridgeRole::kTopWeight}}));
  EXPECT_EQ(Roles(verified.rejected),
            (std::set<std::pair<ImagePair, BridgeRole>>{
                {ImagePair(3, 5), BridgeRole::kTopWeight}}));
  for (const BridgeRecord& b : verified.bridges) EXPECT_TRUE(b.accepted);
}

// Communities A = {1, 2}, B = {3, 4}, C = {5, 6}. Bridges (rank = the larger
// of the pair's places among its two images' pairs by weight): A-C (1,5)
// 800, rank 2; A-C (1,6) 700, rank 3; A-B (1,4) 500, rank 4 (image 1 has
// 1-2, 1-5 and 1-6 above it); A-B (2,3) 300, rank 2.
ViewGraph RankedBridges() {
  return ViewGraph::FromEdges(
      {1, 2, 3, 4, 5, 6},
      {{ImagePair(1, 2), 1000}, {ImagePair(3, 4), 1001},
       {ImagePair(5, 6), 1002}, {ImagePair(1, 5), 800},
       {ImagePair(1, 6), 700},  {ImagePair(1, 4), 500},
       {ImagePair(2, 3), 300}});
}

TEST(Skeleton, RankTiersTakeMutuallyStrongBridgesBeforeHeavierOnes) {
  const ViewGraph g = RankedBridges();
  const Communities c = ComputeCommunities(g, CommunityOptions());
  SkeletonOptions options = OneTreeByWeight();
  using RoleSet = std::set<std::pair<ImagePair, BridgeRole>>;
  // Algorithm 1's order (by weight) joins A-B through (1,4).
  const Skeleton by_weight = BuildSkeleton(g, c, nullptr, options);
  EXPECT_EQ(Roles(by_weight.bridges),
            (RoleSet{{ImagePair(1, 5), BridgeRole::kTree},
                    {ImagePair(1, 4), BridgeRole::kTree}}));
  // Tier 2 holds (1,5) and (2,3): the lighter (2,3) joins A-B.
  for (const int tiers : {2, 3}) {
    options.rank_tiers = tiers;
    const Skeleton tiered = BuildSkeleton(g, c, nullptr, options);
    EXPECT_EQ(Roles(tiered.bridges),
              (RoleSet{{ImagePair(1, 5), BridgeRole::kTree},
                      {ImagePair(2, 3), BridgeRole::kTree}}))
        << tiers;
  }
  // Verified in the tiers' order: a rejected (2,3) leaves A-B to the
  // bridges past the tiers, (1,4) (rank 4), not scored before (2,3).
  options.rank_tiers = 3;
  RecordingScorer scorer;
  scorer.reject = {ImagePair(2, 3)};
  const Skeleton verified = BuildSkeleton(g, c, &scorer, options);
  EXPECT_EQ(scorer.calls, (std::vector<ImagePair>{
                              ImagePair(1, 5), ImagePair(2, 3),
                              ImagePair(1, 4)}));
  EXPECT_EQ(Roles(verified.bridges),
            (RoleSet{{ImagePair(1, 5), BridgeRole::kTree},
                    {ImagePair(1, 4), BridgeRole::kTree}}));
  options.rank_tiers = -1;
  EXPECT_THROW(options.Check(), Error);
}

TEST(Skeleton, MaxBridgeRankLeavesOutBridgesFarDownTheirImagesLists) {
  const ViewGraph g = RankedBridges();
  const Communities c = ComputeCommunities(g, CommunityOptions());
  SkeletonOptions options = OneTreeByWeight();
  using RoleSet = std::set<std::pair<ImagePair, BridgeRole>>;
  // With (2,3) rejected, only (1,4) (rank 4) joins A-B; a cap at rank 3
  // leaves it out, unscored, and A-B stays apart.
  options.rank_tiers = 3;
  options.max_bridge_rank = 3;
  RecordingScorer scorer;
  scorer.reject = {ImagePair(2, 3)};
  const Skeleton capped = BuildSkeleton(g, c, &scorer, options);
  EXPECT_EQ(scorer.calls,
            (std::vector<ImagePair>{ImagePair(1, 5), ImagePair(2, 3)}));
  EXPECT_EQ(Roles(capped.bridges),
            (RoleSet{{ImagePair(1, 5), BridgeRole::kTree}}));
  EXPECT_EQ(capped.num_rank_excluded, 1u);
  EXPECT_EQ(capped.num_candidate_bridges, 4u);
  // At rank 4 it is a bridge again (and without tiers the cap still ranks).
  options.rank_tiers = 0;
  options.max_bridge_rank = 4;
  const Skeleton at_four = BuildSkeleton(g, c, nullptr, options);
  EXPECT_EQ(Roles(at_four.bridges),
            (RoleSet{{ImagePair(1, 5), BridgeRole::kTree},
                    {ImagePair(1, 4), BridgeRole::kTree}}));
  EXPECT_EQ(at_four.num_rank_excluded, 0u);
  options.max_bridge_rank = -1;
  EXPECT_THROW(options.Check(), Error);
}

// Communities A = {1, 2}, B = {3, 4}, C = {5, 6} joined only by weak
// bridges: A-B (1,3) 40, (2,4) 30, (2,3) 20; A-C (1,5) 45, (2,6) 35.
ViewGraph WeaklyJoinedCommunities() {
  return ViewGraph::FromEdges(
      {1, 2, 3, 4, 5, 6},
      {{ImagePair(1, 2), 1000}, {ImagePair(3, 4), 1001},
       {ImagePair(5, 6), 1002}, {ImagePair(1, 3), 40},
       {ImagePair(2, 4), 30},   {ImagePair(2, 3), 20},
       {ImagePair(1, 5), 45},   {ImagePair(2, 6), 35}});
}

TEST(Skeleton, BackupBridgesPerWeakCommunityPair) {
  const ViewGraph g = WeaklyJoinedCommunities();
  const Communities c = ComputeCommunities(g, CommunityOptions());
  ASSERT_EQ(c.NumCommunities(), 3u);
  SkeletonOptions options;
  options.num_trees = 1;
  options.weak_link_max_inliers = 50;
  // Three communities: the default budget (two verifications) would stop
  // the backups below.
  options.redundant_budget_trees = 10;
  using Roleset = std::set<std::pair<ImagePair, BridgeRole>>;
  const Roleset tree = {{ImagePair(1, 5), BridgeRole::kTree},
                        {ImagePair(1, 3), BridgeRole::kTree}};
  auto with = [&](Roleset extra) {
    extra.insert(tree.begin(), tree.end());
    return extra;
  };

  // One backup per weak pair of communities, the heaviest left.
  options.num_backup_bridges = 1;
  EXPECT_EQ(Roles(BuildSkeleton(g, c, nullptr, options).bridges),
            with({{ImagePair(2, 4), BridgeRole::kBackup},
                  {ImagePair(2, 6), BridgeRole::kBackup}}));
  // Two: A-B has two more bridges, A-C only one.
  options.num_backup_bridges = 2;
  EXPECT_EQ(Roles(BuildSkeleton(g, c, nullptr, options).bridges),
            with({{ImagePair(2, 4), BridgeRole::kBackup},
                  {ImagePair(2, 3), BridgeRole::kBackup},
                  {ImagePair(2, 6), BridgeRole::kBackup}}));
  // None asked for, or no weak link (both tree bridges reach 40 inliers).
  options.num_backup_bridges = 0;
  EXPECT_EQ(Roles(BuildSkeleton(g, c, nullptr, options).bridges), tree);
  options.num_backup_bridges = 1;
  options.weak_link_max_inliers = 40;
  EXPECT_EQ(Roles(BuildSkeleton(g, c, nullptr, options).bridges), tree);

  // Backups are verified: a rejected (2,4) gives way to (2,3).
  options.weak_link_max_inliers = 50;
  RecordingScorer scorer;
  scorer.reject = {ImagePair(2, 4)};
  const Skeleton s = BuildSkeleton(g, c, &scorer, options);
  EXPECT_EQ(Roles(s.bridges), with({{ImagePair(2, 3), BridgeRole::kBackup},
                                    {ImagePair(2, 6), BridgeRole::kBackup}}));
  EXPECT_EQ(Roles(s.rejected),
            (Roleset{{ImagePair(2, 4), BridgeRole::kBackup}}));

  // The default budget, two verifications after the tree (m - 1 = 2),
  // caps the three backups a verifier that passes them all would give.
  SkeletonOptions capped = options;
  capped.redundant_budget_trees = 1;
  capped.num_backup_bridges = 2;
  RecordingScorer all_pass;
  const Skeleton k = BuildSkeleton(g, c, &all_pass, capped);
  EXPECT_EQ(k.bridges.size(), 4u);
  EXPECT_EQ(k.num_verified, 4u);
}

TEST(Hierarchy, EveryLeafIsAttachedToItsScaffold) {
  for (uint32_t seed = 0; seed < 10; ++seed) {
    const ViewGraph g = ClusteredGraph(6, 8, 0.1, seed);
    HierarchyOptions options;
    const Hierarchy h = BuildHierarchy(g, nullptr, options);
    const auto& c = h.communities;
    std::set<ImageId> attached;
    for (const ViewGraphEdge& e : h.leaf_edges) {
      EXPECT_EQ(c.Of(e.pair.image_id1), c.Of(e.pair.image_id2));
      EXPECT_TRUE(!h.skeleton.Contains(e.pair.image_id1) ||
                  !h.skeleton.Contains(e.pair.image_id2));
      attached.insert(e.pair.image_id1);
      attached.insert(e.pair.image_id2);
    }
    ASSERT_EQ(h.components.size(), 1u);
    const HierarchyComponent& comp = h.components[0];
    EXPECT_EQ(comp.images.size(), g.NumImages());
    for (ImageId id : g.Images()) {
      if (!h.skeleton.Contains(id)) {
        EXPECT_TRUE(attached.count(id)) << id;
      }
    }
    EXPECT_LT(h.Edges().size(), g.NumEdges());
  }
}

TEST(Hierarchy, DisconnectedGraphGivesOneComponentEach) {
  // Two separate groups and one isolated image.
  const ViewGraph g = ViewGraph::FromEdges(
      {1, 2, 3, 4, 5, 6, 7, 8, 9},
      {{ImagePair(1, 2), 300}, {ImagePair(3, 4), 300}, {ImagePair(2, 3), 50},
       {ImagePair(1, 4), 40},  {ImagePair(5, 6), 300}, {ImagePair(7, 8), 280},
       {ImagePair(6, 7), 60}});
  const Hierarchy h = BuildHierarchy(g, nullptr, HierarchyOptions());
  ASSERT_EQ(h.components.size(), 2u);
  EXPECT_EQ(h.components[0].images.size(), 4u);
  EXPECT_EQ(h.components[1].images.size(), 4u);
  EXPECT_EQ(h.isolated_images, std::vector<ImageId>{9});
  for (const HierarchyComponent& comp : h.components) {
    EXPECT_FALSE(comp.skeleton_images.empty());
  }
}

TEST(Hierarchy, SingleCommunityIsItsOwnScaffold) {
  const ViewGraph g = ViewGraph::FromEdges(
      {1, 2, 3}, {{ImagePair(1, 2), 300}, {ImagePair(2, 3), 200},
                  {ImagePair(1, 3), 100}});
  const Hierarchy h = BuildHierarchy(g, nullptr, HierarchyOptions());
  EXPECT_EQ(h.communities.NumCommunities(), 1u);
  EXPECT_TRUE(h.skeleton.bridges.empty());
  ASSERT_EQ(h.components.size(), 1u);
  EXPECT_EQ(h.components[0].skeleton_images.size(), 3u);
}

TEST(Hierarchy, RejectedBridgesCanLeaveAForest) {
  // The only bridge between the two communities is rejected.
  const ViewGraph g = ViewGraph::FromEdges(
      {1, 2, 3, 4}, {{ImagePair(1, 2), 300}, {ImagePair(3, 4), 300},
                     {ImagePair(2, 3), 50}});
  RecordingScorer scorer;
  scorer.reject.insert(ImagePair(2, 3));
  const Hierarchy h = BuildHierarchy(g, &scorer, HierarchyOptions());
  EXPECT_TRUE(h.skeleton.bridges.empty());
  ASSERT_EQ(h.skeleton.rejected.size(), 1u);
  EXPECT_EQ(h.components.size(), 2u);
}

// Scores each pair from a table (0.9 for pairs not in it) and records calls.
class TableScorer : public BridgeScorer {
 public:
  std::map<ImagePair, double> scores;
  std::vector<ImagePair> calls;
  size_t batch = 1;
  std::string Name() const override { return "table"; }
  size_t PreferredBatchSize() const override { return batch; }
  std::vector<double> Score(const std::vector<ImagePair>& pairs) override {
    std::vector<double> s;
    for (const ImagePair& p : pairs) {
      calls.push_back(p);
      auto it = scores.find(p);
      s.push_back(it == scores.end() ? 0.9 : it->second);
    }
    return s;
  }
};

// Two communities {1, 2} and {3, 4} (strong internal edges) and three
// bridges between them, heaviest first: (2, 3), (1, 4), (1, 3).
ViewGraph TwoCommunityGraph() {
  return ViewGraph::FromEdges(
      {1, 2, 3, 4}, {{ImagePair(1, 2), 300},
                     {ImagePair(3, 4), 300},
                     {ImagePair(2, 3), 50},
                     {ImagePair(1, 4), 40},
                     {ImagePair(1, 3), 30}});
}

std::vector<BridgeRecord> BridgesWithRole(const Skeleton& s, BridgeRole role) {
  std::vector<BridgeRecord> out;
  for (const BridgeRecord& b : s.bridges) {
    if (b.role == role) out.push_back(b);
  }
  return out;
}

TEST(Skeleton, FallbackJoinsCommunitiesThroughTheBestScoredBridge) {
  const ViewGraph g = TwoCommunityGraph();
  const Communities c = ComputeCommunities(g, CommunityOptions());
  ASSERT_EQ(c.NumCommunities(), 2u);
  TableScorer scorer;
  // Every bridge fails tau = 0.5; (1, 4), not the heaviest, scores best.
  scorer.scores = {{ImagePair(2, 3), 0.2},
                   {ImagePair(1, 4), 0.35},
                   {ImagePair(1, 3), 0.1}};
  SkeletonOptions options;
  options.verify_threshold = 0.5;
  options.fallback_threshold = 0.3;
  const Skeleton s = BuildSkeleton(g, c, &scorer, options);
  // Kruskal scored every bridge once; the fallback scored none.
  EXPECT_EQ(scorer.calls.size(), 3u);
  EXPECT_EQ(s.num_verified, 3u);
  ASSERT_EQ(s.bridges.size(), 1u);
  const BridgeRecord& b = s.bridges[0];
  EXPECT_EQ(b.role, BridgeRole::kFallback);
  EXPECT_EQ(b.pair, ImagePair(1, 4));
  EXPECT_DOUBLE_EQ(b.score, 0.35);
  EXPECT_TRUE(b.accepted);
  EXPECT_EQ(b.tree, -1);
  EXPECT_NE(b.community1, b.community2);
  EXPECT_TRUE(s.Contains(1));
  EXPECT_TRUE(s.Contains(4));

  // The hierarchy is one component through that bridge.
  HierarchyOptions hierarchy_options;
  hierarchy_options.skeleton = options;
  TableScorer scorer2;
  scorer2.scores = scorer.scores;
  const Hierarchy h = BuildHierarchy(g, &scorer2, hierarchy_options);
  ASSERT_EQ(h.components.size(), 1u);
  EXPECT_EQ(h.components[0].images.size(), 4u);
  const std::vector<ImagePair> edges = h.Edges();
  EXPECT_TRUE(std::binary_search(edges.begin(), edges.end(), ImagePair(1, 4)));
  EXPECT_FALSE(std::binary_search(edges.begin(), edges.end(), ImagePair(2, 3)));
  EXPECT_FALSE(std::binary_search(edges.begin(), edges.end(), ImagePair(1, 3)));
}

TEST(Skeleton, FirstTreeBudgetJoinsThroughTheBestNearMiss) {
  const ViewGraph g = TwoCommunityGraph();
  const Communities c = ComputeCommunities(g, CommunityOptions());
  ASSERT_EQ(c.NumCommunities(), 2u);
  SkeletonOptions options;
  options.num_trees = 1;
  options.verify_threshold = 0.8;
  options.fallback_threshold = 0.5;
  options.num_backup_bridges = 0;  // (1, 3) would back up the weak (1, 4)
  // Builds with `budget`, scoring from a table in which only the lightest
  // bridge passes tau = 0.8 and (1, 4) is the best near miss; the pairs
  // scored go to `calls`.
  auto build = [&](double budget, std::vector<ImagePair>* calls,
                   size_t batch = 1) {
    options.first_tree_budget_trees = budget;
    TableScorer scorer;
    scorer.batch = batch;
    scorer.scores = {{ImagePair(2, 3), 0.6},
                     {ImagePair(1, 4), 0.7},
                     {ImagePair(1, 3), 0.9}};
    Skeleton s = BuildSkeleton(g, c, &scorer, options);
    *calls = scorer.calls;
    return s;
  };
  const std::vector<ImagePair> all_three = {ImagePair(2, 3), ImagePair(1, 4),
                                            ImagePair(1, 3)};
  std::vector<ImagePair> calls;

  // No budget (Algorithm 1): Kruskal scores its way down to (1, 3).
  const Skeleton all = build(0, &calls);
  EXPECT_EQ(calls, all_three);
  ASSERT_EQ(all.bridges.size(), 1u);
  EXPECT_EQ(all.bridges[0].pair, ImagePair(1, 3));
  EXPECT_EQ(all.bridges[0].role, BridgeRole::kTree);

  // Two trees' worth of one edge: two scores, then the best of them joins
  // the communities; (1, 3) is neither scored nor recorded as rejected.
  const Skeleton s = build(2, &calls);
  EXPECT_EQ(calls, (std::vector<ImagePair>{ImagePair(2, 3), ImagePair(1, 4)}));
  EXPECT_EQ(s.num_verified, 2u);
  EXPECT_EQ(s.num_verified_first_tree, 2u);
  ASSERT_EQ(s.bridges.size(), 1u);
  EXPECT_EQ(s.bridges[0].pair, ImagePair(1, 4));
  EXPECT_EQ(s.bridges[0].role, BridgeRole::kFallback);
  ASSERT_EQ(s.rejected.size(), 2u);
  for (const BridgeRecord& r : s.rejected) {
    EXPECT_NE(r.pair, ImagePair(1, 3));
  }

  // Speculative batches stop at the budget too (a batch of two would score
  // (1, 4) and (1, 3) together).
  const Skeleton batched = build(2, &calls, /*batch=*/8);
  EXPECT_EQ(calls, (std::vector<ImagePair>{ImagePair(2, 3), ImagePair(1, 4)}));
  ASSERT_EQ(batched.bridges.size(), 1u);
  EXPECT_EQ(batched.bridges[0].pair, ImagePair(1, 4));

  // A budget the tree does not reach changes nothing.
  const Skeleton roomy = build(3, &calls);
  EXPECT_EQ(calls, all_three);
  ASSERT_EQ(roomy.bridges.size(), 1u);
  EXPECT_EQ(roomy.bridges[0].pair, ImagePair(1, 3));

  // Without a fallback (its threshold at tau) there is no budget.
  options.fallback_threshold = 0.8;
  const Skeleton no_fallback = build(2, &calls);
  EXPECT_EQ(calls, all_three);
  ASSERT_EQ(no_fallback.bridges.size(), 1u);
  EXPECT_EQ(no_fallback.bridges[0].pair, ImagePair(1, 3));

  options.first_tree_budget_trees = -1;
  EXPECT_THROW(options.Check(), Error);
  options.first_tree_budget_trees = INFINITY;
  EXPECT_THROW(options.Check(), Error);
}

TEST(Skeleton, PastItsBudgetTheFirstTreeGoesOnAtTheFallbackThreshold) {
  // Communities {1, 2}, {3, 4} and {5, 6}; bridges by weight: (2, 3) A-B,
  // (4, 5) B-C, (3, 6) B-C, (1, 5) A-C.
  const ViewGraph g = ViewGraph::FromEdges(
      {1, 2, 3, 4, 5, 6}, {{ImagePair(1, 2), 300},
                           {ImagePair(3, 4), 300},
                           {ImagePair(5, 6), 300},
                           {ImagePair(2, 3), 60},
                           {ImagePair(4, 5), 58},
                           {ImagePair(3, 6), 56},
                           {ImagePair(1, 5), 54}});
  const Communities c = ComputeCommunities(g, CommunityOptions());
  ASSERT_EQ(c.NumCommunities(), 3u);
  const std::map<ImagePair, double> scores = {{ImagePair(2, 3), 0.6},
                                              {ImagePair(4, 5), 0.2},
                                              {ImagePair(3, 6), 0.7},
                                              {ImagePair(1, 5), 0.9}};
  SkeletonOptions options;
  options.num_trees = 1;
  options.rank_tiers = 0;
  options.num_backup_bridges = 0;
  options.verify_threshold = 0.8;
  options.fallback_threshold = 0.5;

  // No budget: Kruskal scores all four and takes (1, 5); the fallback
  // joins B-C through (3, 6).
  options.first_tree_budget_trees = 0;
  TableScorer unlimited;
  unlimited.scores = scores;
  const Skeleton all = BuildSkeleton(g, c, &unlimited, options);
  EXPECT_EQ(unlimited.calls.size(), 4u);
  EXPECT_EQ(Roles(all.bridges),
            (std::set<std::pair<ImagePair, BridgeRole>>{
                {ImagePair(1, 5), BridgeRole::kTree},
                {ImagePair(3, 6), BridgeRole::kFallback}}));

  // One tree's worth (two scores): the near miss (2, 3) joins A-B, and the
  // scan goes on at 0.5, scoring (3, 6) and taking it; (1, 5) is never
  // scored.
  options.first_tree_budget_trees = 1;
  TableScorer budgeted;
  budgeted.scores = scores;
  const Skeleton s = BuildSkeleton(g, c, &budgeted, options);
  EXPECT_EQ(budgeted.calls,
            (std::vector<ImagePair>{ImagePair(2, 3), ImagePair(4, 5),
                                    ImagePair(3, 6)}));
  EXPECT_EQ(s.num_verified_first_tree, 3u);
  EXPECT_EQ(Roles(s.bridges),
            (std::set<std::pair<ImagePair, BridgeRole>>{
                {ImagePair(2, 3), BridgeRole::kFallback},
                {ImagePair(3, 6), BridgeRole::kFallback}}));
  for (const BridgeRecord& b : s.bridges) EXPECT_EQ(b.tree, -1);
}

TEST(Skeleton, FallbackNeedsTheFallbackThreshold) {
  const ViewGraph g = TwoCommunityGraph();
  const Communities c = ComputeCommunities(g, CommunityOptions());
  TableScorer scorer;
  scorer.scores = {{ImagePair(2, 3), 0.2},
                   {ImagePair(1, 4), 0.25},
                   {ImagePair(1, 3), 0.1}};
  SkeletonOptions options;
  options.verify_threshold = 0.5;
  options.fallback_threshold = 0.3;  // above every score
  const Skeleton s = BuildSkeleton(g, c, &scorer, options);
  EXPECT_TRUE(s.bridges.empty());
  EXPECT_EQ(s.rejected.size(), 3u);
  // A score equal to the fallback threshold is enough.
  options.fallback_threshold = 0.25;
  TableScorer scorer2;
  scorer2.scores = scorer.scores;
  const Skeleton s2 = BuildSkeleton(g, c, &scorer2, options);
  ASSERT_EQ(s2.bridges.size(), 1u);
  EXPECT_EQ(s2.bridges[0].pair, ImagePair(1, 4));
  EXPECT_EQ(s2.bridges[0].role, BridgeRole::kFallback);
}

TEST(Skeleton, FallbackOffWhenNotBelowVerifyThreshold) {
  const ViewGraph g = TwoCommunityGraph();
  const Communities c = ComputeCommunities(g, CommunityOptions());
  for (const double fallback : {0.5, 0.7}) {
    TableScorer scorer;
    scorer.scores = {{ImagePair(2, 3), 0.2},
                     {ImagePair(1, 4), 0.45},
                     {ImagePair(1, 3), 0.1}};
    SkeletonOptions options;
    options.verify_threshold = 0.5;
    options.fallback_threshold = fallback;
    const Skeleton s = BuildSkeleton(g, c, &scorer, options);
    EXPECT_TRUE(s.bridges.empty()) << "fallback " << fallback;
    EXPECT_EQ(s.rejected.size(), 3u);
    HierarchyOptions hierarchy_options;
    hierarchy_options.skeleton = options;
    TableScorer scorer2;
    scorer2.scores = scorer.scores;
    const Hierarchy h = BuildHierarchy(g, &scorer2, hierarchy_options);
    EXPECT_EQ(h.components.size(), 2u) << "fallback " << fallback;
  }
}

TEST(Skeleton, FallbackOnlyJoinsWhatTheTreesLeftApart) {
  // Three chains (communities of 5); cluster 0-1 bridges pass, every bridge
  // touching cluster 2 fails tau but scores at least the fallback threshold.
  for (uint32_t seed = 0; seed < 5; ++seed) {
    const ViewGraph g = ClusteredGraph(3, 5, 0.3, seed);
    const Communities c = ComputeCommunities(g, CommunityOptions());
    std::set<CommunityId> third;
    for (ImageId id = 11; id <= 15; ++id) third.insert(c.Of(id));
    TableScorer scorer;
    std::mt19937 rng(seed);
    std::uniform_real_distribution<double> u(0.3, 0.45);
    size_t num_third_bridges = 0;
    for (const ViewGraphEdge& e : g.Edges()) {
      const CommunityId a = c.Of(e.pair.image_id1);
      const CommunityId b = c.Of(e.pair.image_id2);
      if (a == b) continue;
      if (third.count(a) != third.count(b)) {
        scorer.scores[e.pair] = u(rng);
        ++num_third_bridges;
      }
    }
    ASSERT_GT(num_third_bridges, 1u);
    SkeletonOptions options;
    options.num_trees = 1;
    options.num_backup_bridges = 0;
    options.verify_threshold = 0.5;
    options.fallback_threshold = 0.25;
    const Skeleton s = BuildSkeleton(g, c, &scorer, options);
    // The communities are connected by the skeleton's bridges.
    UnionFind uf(c.NumCommunities());
    for (const BridgeRecord& b : s.bridges) {
      EXPECT_TRUE(uf.Union(b.community1, b.community2)) << "seed " << seed;
    }
    size_t joined = 0;
    for (CommunityId k = 1; k < c.NumCommunities(); ++k) {
      joined += uf.Connected(0, k);
    }
    EXPECT_EQ(joined, c.NumCommunities() - 1) << "seed " << seed;
    // Fallback bridges only where no bridge passed: each one touches the
    // third cluster and is the best-scoring bridge between the two sides
    // it joins at that point; tree bridges all pass tau.
    const std::vector<BridgeRecord> fallback =
        BridgesWithRole(s, BridgeRole::kFallback);
    EXPECT_FALSE(fallback.empty()) << "seed " << seed;
    for (const BridgeRecord& b : s.bridges) {
      if (b.role == BridgeRole::kFallback) {
        EXPECT_LT(b.score, options.verify_threshold);
        EXPECT_GE(b.score, options.fallback_threshold);
        EXPECT_NE(third.count(b.community1), third.count(b.community2));
      } else {
        EXPECT_GE(b.score, options.verify_threshold);
      }
    }
    // The first fallback bridge is the best-scored rejected bridge overall.
    double best = 0;
    for (const BridgeRecord& r : s.rejected) best = std::max(best, r.score);
    EXPECT_DOUBLE_EQ(fallback.front().score, best) << "seed " << seed;
    // The fallback scored nothing itself.
    EXPECT_EQ(scorer.calls.size(), s.num_verified);
  }
}

TEST(Skeleton, NoFallbackWhenTheTreesSpan) {
  const ViewGraph g = TwoCommunityGraph();
  const Communities c = ComputeCommunities(g, CommunityOptions());
  TableScorer scorer;
  // The heaviest bridge fails, the next passes: the tree spans.
  scorer.scores = {{ImagePair(2, 3), 0.45},
                   {ImagePair(1, 4), 0.8},
                   {ImagePair(1, 3), 0.4}};
  SkeletonOptions options;
  options.num_backup_bridges = 0;
  options.verify_threshold = 0.5;
  options.fallback_threshold = 0.1;
  const Skeleton s = BuildSkeleton(g, c, &scorer, options);
  ASSERT_EQ(s.bridges.size(), 1u);
  EXPECT_EQ(s.bridges[0].pair, ImagePair(1, 4));
  EXPECT_EQ(s.bridges[0].role, BridgeRole::kTree);
  EXPECT_TRUE(BridgesWithRole(s, BridgeRole::kFallback).empty());
}

TEST(Skeleton, FallbackThresholdOutOfRangeIsRejected) {
  SkeletonOptions options;
  options.fallback_threshold = -0.1;
  EXPECT_THROW(options.Check(), Error);
  options.fallback_threshold = 1.5;
  EXPECT_THROW(options.Check(), Error);
  options.fallback_threshold = 0.0;
  EXPECT_NO_THROW(options.Check());
}

}  // namespace
}  // namespace hisfm

namespace hisfm {
namespace {

// Accepts every bridge (score 0.9); a cycle turns by 180 degrees per
// "folded" pair on it (a doppelganger of a two-fold symmetric object), and
// by `turn` degrees per pair in it walked from the lower id to the higher
// (minus that the other way); every cycle asked about is recorded, and each
// of its steps must be an edge of `graph` when given.
class CycleScorer : public BridgeScorer {
 public:
  std::set<ImagePair> folded;
  std::map<ImagePair, double> turn;
  const ViewGraph* graph = nullptr;
  std::vector<std::vector<ImageId>> cycles;
  // Pairs scored 0.1 (below tau) and 0.6 (near misses at tau = 0.8);
  // every other pair 0.9.
  std::set<ImagePair> weak;
  std::set<ImagePair> middling;
  // Scores that override both sets.
  std::map<ImagePair, double> exact;
  // Whether the scorer reports rotations at all.
  bool knows_rotations = true;
  std::string Name() const override { return "cycle"; }
  std::vector<double> Score(const std::vector<ImagePair>& pairs) override {
    std::vector<double> s;
    for (const ImagePair& p : pairs) {
      const auto it = exact.find(p);
      s.push_back(it != exact.end() ? it->second
                  : weak.count(p)   ? 0.1
                  : middling.count(p) ? 0.6
                                      : 0.9);
    }
    return s;
  }
  double CycleRotationErrorDeg(const std::vector<ImageId>& cycle) override {
    if (!knows_rotations) return -1.0;
    cycles.push_back(cycle);
    double total = 0.0;
    for (size_t k = 0; k < cycle.size(); ++k) {
      const ImageId u = cycle[k];
      const ImageId v = cycle[(k + 1) % cycle.size()];
      const ImagePair p(u, v);
      if (graph != nullptr) {
        EXPECT_GT(graph->Weight(u, v), 0u) << u << "-" << v << " not an edge";
      }
      total += folded.count(p) ? 180.0 : 0.0;
      const auto it = turn.find(p);
      if (it != turn.end()) total += u < v ? it->second : -it->second;
    }
    const double error = std::fmod(std::abs(total), 360.0);
    return error > 180.0 ? 360.0 - error : error;
  }
};

TEST(SkeletonCycles, LaterTreesRejectBridgesThatTurnTheirLoop) {
  const ViewGraph g = ClusteredGraph(6, 4, 0.5, 3);
  const Communities c = ComputeCommunities(g, CommunityOptions());
  ASSERT_GT(c.NumCommunities(), 2u);
  // Fold the heaviest bridges after the first tree would have been built:
  // every bridge not in the first tree of an unchecked build.
  SkeletonOptions options;
  options.num_trees = 1;
  options.num_backup_bridges = 0;
  CycleScorer plain;
  const Skeleton first = BuildSkeleton(g, c, &plain, options);
  EXPECT_TRUE(plain.cycles.empty()) << "one tree closes no cycle";
  std::set<ImagePair> tree_pairs;
  for (const BridgeRecord& b : first.bridges) tree_pairs.insert(b.pair);

  CycleScorer scorer;
  for (const ViewGraphEdge& e : g.Edges()) {
    if (c.Of(e.pair.image_id1) != c.Of(e.pair.image_id2) &&
        !tree_pairs.count(e.pair) && e.pair.image_id1 % 2 == 0) {
      scorer.folded.insert(e.pair);
    }
  }
  ASSERT_FALSE(scorer.folded.empty());
  options.num_trees = 2;
  const Skeleton checked = BuildSkeleton(g, c, &scorer, options);
  EXPECT_FALSE(scorer.cycles.empty());
  size_t num_cycle_rejected = 0;
  for (const BridgeRecord& b : checked.bridges) {
    EXPECT_FALSE(scorer.folded.count(b.pair))
        << b.pair.image_id1 << "-" << b.pair.image_id2 << " taken";
    if (b.tree == 0) {
      EXPECT_LT(b.cycle_error_deg, 0.0);
    } else if (b.tree == 1) {
      EXPECT_EQ(b.cycle_error_deg, 0.0);
    }
  }
  for (const BridgeRecord& b : checked.rejected) {
    if (b.cycle_error_deg >= 0) {
      EXPECT_EQ(b.cycle_error_deg, 180.0);
      EXPECT_TRUE(scorer.folded.count(b.pair));
      EXPECT_LT(b.score, 0.0) << "rejected by its cycle before scoring";
      ++num_cycle_rejected;
    }
  }
  EXPECT_GT(num_cycle_rejected, 0u);
  // Every scored bridge passed (the scorer accepts all): only the bridges
  // taken were scored.
  EXPECT_EQ(checked.num_verified, checked.bridges.size());
  // Each cycle asked about runs over the communities' top-k edges and the
  // bridges taken before, from one end of the bridge to the other.
  std::set<ImagePair> held;
  for (const ViewGraphEdge& e : c.top_k_edges) held.insert(e.pair);
  for (const BridgeRecord& b : checked.bridges) held.insert(b.pair);
  for (const std::vector<ImageId>& cycle : scorer.cycles) {
    ASSERT_GE(cycle.size(), 2u);
    EXPECT_GT(g.Weight(cycle.front(), cycle.back()), 0u);
    for (size_t k = 0; k + 1 < cycle.size(); ++k) {
      EXPECT_TRUE(held.count(ImagePair(cycle[k], cycle[k + 1])));
    }
  }

  // Off: the folded bridges are taken like any other.
  options.max_cycle_rotation_deg = 0;
  CycleScorer off;
  off.folded = scorer.folded;
  const Skeleton unchecked = BuildSkeleton(g, c, &off, options);
  EXPECT_TRUE(off.cycles.empty());
  size_t num_folded_taken = 0;
  for (const BridgeRecord& b : unchecked.bridges) {
    num_folded_taken += off.folded.count(b.pair);
  }
  EXPECT_GT(num_folded_taken, 0u);
}

TEST(SkeletonCycles, ARejectionForTheScoreKeepsTheCycleChecked) {
  const ViewGraph g = ClusteredGraph(6, 4, 0.5, 3);
  const Communities c = ComputeCommunities(g, CommunityOptions());
  SkeletonOptions options;
  options.num_trees = 2;
  options.num_backup_bridges = 0;
  // Every bridge scores low except those the first tree of an all-passing
  // build takes: the second tree meets consistent cycles and rejects
  // bridges for their score only.
  CycleScorer probe;
  options.num_trees = 1;
  const Skeleton first = BuildSkeleton(g, c, &probe, options);
  CycleScorer scorer;
  for (const ViewGraphEdge& e : g.Edges()) {
    if (c.Of(e.pair.image_id1) != c.Of(e.pair.image_id2)) {
      scorer.weak.insert(e.pair);
    }
  }
  for (const BridgeRecord& b : first.bridges) scorer.weak.erase(b.pair);
  options.num_trees = 2;
  const Skeleton built = BuildSkeleton(g, c, &scorer, options);
  size_t num_checked = 0;
  for (const BridgeRecord& b : built.rejected) {
    EXPECT_DOUBLE_EQ(b.score, 0.1);
    if (b.tree < 0 && b.cycle_error_deg >= 0) {
      EXPECT_EQ(b.cycle_error_deg, 0.0);
      ++num_checked;
    }
  }
  EXPECT_GT(num_checked, 0u) << "second-tree rejections carry their cycle";
}

// Two communities, the chains 1-2-3 and 4-5-6, and three bridges: 3-4 (300
// inliers) and 1-6 (280), both true, and 2-5 (100), a doppelganger that
// turns every loop it is on by 180 degrees. 2-5 meets the trees last (rank
// 3 against 2).
ViewGraph NearMissGraph() {
  return ViewGraph::FromEdges(
      {1, 2, 3, 4, 5, 6},
      {{ImagePair(1, 2), 1000}, {ImagePair(2, 3), 1010},
       {ImagePair(4, 5), 1020}, {ImagePair(5, 6), 1030},
       {ImagePair(3, 4), 300}, {ImagePair(1, 6), 280},
       {ImagePair(2, 5), 100}});
}

// tau = 0.8; the true bridges score 0.6 (near misses), the doppelganger 0.9.
CycleScorer NearMissScorer() {
  CycleScorer scorer;
  scorer.middling = {ImagePair(3, 4), ImagePair(1, 6)};
  scorer.folded = {ImagePair(2, 5)};
  return scorer;
}

// The paper's tau = 0.8, above the default fallback threshold (0.5): the
// bridges scoring 0.5 to 0.8 are near misses.
SkeletonOptions PaperTau() {
  SkeletonOptions options;
  options.verify_threshold = 0.8;
  return options;
}

std::set<ImagePair> TakenPairs(const Skeleton& s) {
  std::set<ImagePair> pairs;
  for (const BridgeRecord& b : s.bridges) pairs.insert(b.pair);
  return pairs;
}

TEST(SkeletonNearMisses, HeavierNearMissesOutvoteADoppelgangerAboveTau) {
  const ViewGraph g = NearMissGraph();
  const Communities c = ComputeCommunities(g, CommunityOptions());
  ASSERT_EQ(c.NumCommunities(), 2u);
  SkeletonOptions options = PaperTau();
  CycleScorer scorer = NearMissScorer();
  scorer.graph = &g;
  const Skeleton s = BuildSkeleton(g, c, &scorer, options);
  // Only Kruskal's three bridges were scored; the vote scored none.
  EXPECT_EQ(s.num_verified, 3u);
  // The tree refused 2-5; the fallback joined the two communities through
  // the best-scoring near miss the others do not outvote: the heavier one.
  ASSERT_EQ(s.bridges.size(), 1u);
  EXPECT_EQ(s.bridges[0].pair, ImagePair(3, 4));
  EXPECT_EQ(s.bridges[0].role, BridgeRole::kFallback);
  EXPECT_EQ(s.num_outvoted, 1u);
  bool refused = false;
  for (const BridgeRecord& b : s.rejected) {
    if (b.pair != ImagePair(2, 5)) continue;
    refused = true;
    EXPECT_DOUBLE_EQ(b.score, 0.9);
    EXPECT_EQ(b.cycle_error_deg, 180.0);
    EXPECT_TRUE(b.outvoted);
  }
  EXPECT_TRUE(refused);
  EXPECT_FALSE(scorer.cycles.empty());

  // Off, or with a scorer that reports no rotations, the tree takes 2-5.
  options.near_miss_vote = false;
  CycleScorer off = NearMissScorer();
  EXPECT_EQ(TakenPairs(BuildSkeleton(g, c, &off, options)),
            std::set<ImagePair>{ImagePair(2, 5)});
  options.near_miss_vote = true;
  CycleScorer blind = NearMissScorer();
  blind.knows_rotations = false;
  EXPECT_EQ(TakenPairs(BuildSkeleton(g, c, &blind, options)),
            std::set<ImagePair>{ImagePair(2, 5)});
}

TEST(SkeletonNearMisses, TheFallbackSkipsAnOutvotedNearMiss) {
  // Every bridge fails tau = 0.8: the doppelganger 1-6 (280) scores best
  // of the near misses, but the heavier 3-4 (300) disagrees with it.
  const ViewGraph g = NearMissGraph();
  const Communities c = ComputeCommunities(g, CommunityOptions());
  SkeletonOptions options = PaperTau();
  CycleScorer scorer;
  scorer.exact = {{ImagePair(3, 4), 0.6}, {ImagePair(1, 6), 0.7}};
  scorer.weak = {ImagePair(2, 5)};
  scorer.folded = {ImagePair(1, 6)};
  const Skeleton s = BuildSkeleton(g, c, &scorer, options);
  ASSERT_EQ(s.bridges.size(), 1u);
  EXPECT_EQ(s.bridges[0].pair, ImagePair(3, 4));
  EXPECT_EQ(s.bridges[0].role, BridgeRole::kFallback);
  EXPECT_EQ(s.num_outvoted, 1u);
  options.near_miss_vote = false;
  CycleScorer off = scorer;
  EXPECT_EQ(TakenPairs(BuildSkeleton(g, c, &off, options)),
            std::set<ImagePair>{ImagePair(1, 6)});
}

TEST(SkeletonNearMisses, ALighterDisagreementDoesNotOutvote) {
  const ViewGraph g = NearMissGraph();
  const Communities c = ComputeCommunities(g, CommunityOptions());
  SkeletonOptions options = PaperTau();
  // Only 1-6 (280) is a near miss; 3-4 (300) passes tau and is taken before
  // it is met, so 2-5 and 1-6 are never asked about.
  CycleScorer scorer = NearMissScorer();
  scorer.middling = {ImagePair(1, 6)};
  EXPECT_EQ(TakenPairs(BuildSkeleton(g, c, &scorer, options)),
            std::set<ImagePair>{ImagePair(3, 4)});
  // One near miss (1-6, 280) against a doppelganger made heavier than it
  // (2-5 at 0.9 with 3-4 scoring low): 280 < 290, the doppelganger stays.
  const ViewGraph heavy = ViewGraph::FromEdges(
      {1, 2, 3, 4, 5, 6},
      {{ImagePair(1, 2), 1000}, {ImagePair(2, 3), 1010},
       {ImagePair(4, 5), 1020}, {ImagePair(5, 6), 1030},
       {ImagePair(3, 4), 300}, {ImagePair(1, 6), 280},
       {ImagePair(2, 5), 290}});
  const Communities heavy_c = ComputeCommunities(heavy, CommunityOptions());
  CycleScorer one = NearMissScorer();
  one.middling = {ImagePair(1, 6)};
  one.weak = {ImagePair(3, 4)};
  EXPECT_EQ(TakenPairs(BuildSkeleton(heavy, heavy_c, &one, options)),
            std::set<ImagePair>{ImagePair(2, 5)});
  EXPECT_TRUE(one.cycles.empty())
      << "a lighter near miss cannot decide the vote: no cycle is asked";
}

TEST(SkeletonNearMisses, NearMissesThatAgreeSupportTheBridge) {
  // 1-6 (280) is a doppelganger like 2-5: their cycle turns twice, by 360
  // degrees, and closes. 280 + 100 outweigh 3-4's 300: 2-5 stays.
  const ViewGraph g = NearMissGraph();
  const Communities c = ComputeCommunities(g, CommunityOptions());
  SkeletonOptions options = PaperTau();
  CycleScorer scorer = NearMissScorer();
  scorer.folded.insert(ImagePair(1, 6));
  const Skeleton s = BuildSkeleton(g, c, &scorer, options);
  EXPECT_EQ(TakenPairs(s), std::set<ImagePair>{ImagePair(2, 5)});
  EXPECT_EQ(s.num_outvoted, 0u);
  EXPECT_EQ(scorer.cycles.size(), 2u);
}

TEST(SkeletonNearMisses, NearMissesOrientedAgainstTheBridgeVoteToo) {
  // Communities {1, 4, 5} and {2, 3, 6}: the near miss 3-4 (300) runs from
  // the second to the first, the doppelganger 1-6 (100, scoring 0.9) from
  // the first to the second. By weight order 3-4 is met first.
  const ViewGraph g = ViewGraph::FromEdges(
      {1, 2, 3, 4, 5, 6},
      {{ImagePair(1, 4), 1000}, {ImagePair(4, 5), 1010},
       {ImagePair(2, 3), 1020}, {ImagePair(3, 6), 1030},
       {ImagePair(3, 4), 300}, {ImagePair(1, 6), 100}});
  const Communities c = ComputeCommunities(g, CommunityOptions());
  ASSERT_EQ(c.NumCommunities(), 2u);
  ASSERT_EQ(c.Of(1), c.Of(4));
  SkeletonOptions options = PaperTau();
  options.rank_tiers = 0;
  CycleScorer scorer;
  scorer.graph = &g;
  scorer.middling = {ImagePair(3, 4)};
  scorer.folded = {ImagePair(1, 6)};
  const Skeleton s = BuildSkeleton(g, c, &scorer, options);
  EXPECT_EQ(TakenPairs(s), std::set<ImagePair>{ImagePair(3, 4)});
  EXPECT_EQ(s.num_outvoted, 1u);
  ASSERT_EQ(scorer.cycles.size(), 1u);
  EXPECT_EQ(scorer.cycles[0], (std::vector<ImageId>{1, 4, 3, 6}));
}

TEST(SkeletonNearMisses, TheFallbackJoinsPartsWhoseCandidatesAllLose) {
  // A four-fold object: the true 3-4 (100), and doppelgangers 1-6 (60,
  // turning 90 degrees) and 2-5 (60, 180); all near misses. Each loses its
  // vote to the other two, and the fallback still joins the two parts
  // through the best-scoring one (ties: the heaviest).
  const ViewGraph g = ViewGraph::FromEdges(
      {1, 2, 3, 4, 5, 6},
      {{ImagePair(1, 2), 1000}, {ImagePair(2, 3), 1010},
       {ImagePair(4, 5), 1020}, {ImagePair(5, 6), 1030},
       {ImagePair(3, 4), 100}, {ImagePair(1, 6), 60},
       {ImagePair(2, 5), 60}});
  const Communities c = ComputeCommunities(g, CommunityOptions());
  SkeletonOptions options = PaperTau();
  CycleScorer scorer;
  scorer.graph = &g;
  scorer.middling = {ImagePair(3, 4), ImagePair(1, 6), ImagePair(2, 5)};
  scorer.turn = {{ImagePair(1, 6), 90.0}};
  scorer.folded = {ImagePair(2, 5)};
  const Skeleton s = BuildSkeleton(g, c, &scorer, options);
  EXPECT_EQ(s.num_outvoted, 3u);
  ASSERT_EQ(s.bridges.size(), 1u);
  EXPECT_EQ(s.bridges[0].pair, ImagePair(3, 4));
  EXPECT_EQ(s.bridges[0].role, BridgeRole::kFallback);
}

TEST(SkeletonNearMisses, NoNearMissesAtTheDefaultThresholds) {
  // tau = fallback_threshold = 0.5: a bridge scoring 0.6 passes, so there
  // is nothing to vote; the tree takes the heaviest true bridge.
  const ViewGraph g = NearMissGraph();
  const Communities c = ComputeCommunities(g, CommunityOptions());
  CycleScorer scorer = NearMissScorer();
  const Skeleton s = BuildSkeleton(g, c, &scorer, SkeletonOptions());
  EXPECT_EQ(TakenPairs(s), std::set<ImagePair>{ImagePair(3, 4)});
  EXPECT_TRUE(scorer.cycles.empty());
}

// NearMissGraph with the chords 1-3 and 4-6 inside the communities, so that
// every bridge is the third pair of both its images (rank 3), and the
// bridges' weights given: 3-4, 1-6 and 2-5, the doppelganger; plus
// `extra` edges.
ViewGraph PeerGraph(uint32_t w34, uint32_t w16, uint32_t w25,
                    const std::vector<ViewGraphEdge>& extra = {}) {
  std::vector<ViewGraphEdge> edges = {
      {ImagePair(1, 2), 1000}, {ImagePair(2, 3), 1010},
      {ImagePair(4, 5), 1020}, {ImagePair(5, 6), 1030},
      {ImagePair(1, 3), 990},  {ImagePair(4, 6), 995},
      {ImagePair(3, 4), w34},  {ImagePair(1, 6), w16},
      {ImagePair(2, 5), w25}};
  edges.insert(edges.end(), extra.begin(), extra.end());
  return ViewGraph::FromEdges({1, 2, 3, 4, 5, 6}, edges);
}

// Default thresholds (no near misses), peers on, rank tiers 1 and 2 only:
// the bridges of PeerGraph (rank 3) meet the tree by weight and are put to
// their peers.
SkeletonOptions PeerVote(int size) {
  SkeletonOptions options;
  options.rank_tiers = 2;
  options.peer_vote_size = size;
  return options;
}

// 2-5 scores 0.6 (above tau, below the redundant threshold) and turns every
// cycle it is on by 180 degrees.
CycleScorer PeerScorer() {
  CycleScorer scorer;
  scorer.middling = {ImagePair(2, 5)};
  scorer.folded = {ImagePair(2, 5)};
  return scorer;
}

TEST(SkeletonPeerVote, HeavierPeersOutvoteTheFirstBridgeBetweenTwoParts) {
  // The first tree meets 2-5 (400) first; its unscored peers 3-4 and 1-6
  // (580 together) disagree with it.
  const ViewGraph g = PeerGraph(300, 280, 400);
  const Communities c = ComputeCommunities(g, CommunityOptions());
  ASSERT_EQ(c.NumCommunities(), 2u);
  CycleScorer scorer = PeerScorer();
  scorer.graph = &g;
  const Skeleton s = BuildSkeleton(g, c, &scorer, PeerVote(8));
  EXPECT_EQ(TakenPairs(s), std::set<ImagePair>{ImagePair(3, 4)});
  EXPECT_EQ(s.bridges[0].role, BridgeRole::kTree);
  EXPECT_EQ(s.bridges[0].rank, 3u);
  EXPECT_EQ(s.num_outvoted, 1u);
  ASSERT_EQ(s.rejected.size(), 1u);
  EXPECT_EQ(s.rejected[0].pair, ImagePair(2, 5));
  EXPECT_TRUE(s.rejected[0].outvoted);
  EXPECT_DOUBLE_EQ(s.rejected[0].score, 0.6);
  EXPECT_EQ(s.rejected[0].cycle_error_deg, 180.0);
  // The peers were not scored: 2-5 and 3-4 only.
  EXPECT_EQ(s.num_verified, 2u);

  // Off, the tree takes the doppelganger.
  CycleScorer off = PeerScorer();
  EXPECT_EQ(TakenPairs(BuildSkeleton(g, c, &off, PeerVote(0))),
            std::set<ImagePair>{ImagePair(2, 5)});
}

TEST(SkeletonPeerVote, StrongOrConfidentBridgesAreNotPutToTheirPeers) {
  const ViewGraph g = PeerGraph(300, 280, 400);
  const Communities c = ComputeCommunities(g, CommunityOptions());
  // In a rank tier (rank 3 <= 4).
  SkeletonOptions tiers = PeerVote(8);
  tiers.rank_tiers = 4;
  CycleScorer a = PeerScorer();
  EXPECT_EQ(TakenPairs(BuildSkeleton(g, c, &a, tiers)),
            std::set<ImagePair>{ImagePair(2, 5)});
  // Scored at the redundant threshold or above.
  CycleScorer b = PeerScorer();
  b.exact = {{ImagePair(2, 5), 0.8}};
  EXPECT_EQ(TakenPairs(BuildSkeleton(g, c, &b, PeerVote(8))),
            std::set<ImagePair>{ImagePair(2, 5)});
}

TEST(SkeletonPeerVote, LighterOrFewerPeersDoNotOutvote) {
  // 2-5 at 600 outweighs its two peers (580).
  const ViewGraph heavy = PeerGraph(300, 280, 600);
  const Communities heavy_c = ComputeCommunities(heavy, CommunityOptions());
  CycleScorer a = PeerScorer();
  EXPECT_EQ(TakenPairs(BuildSkeleton(heavy, heavy_c, &a, PeerVote(8))),
            std::set<ImagePair>{ImagePair(2, 5)});
  // At 400 it outweighs the heaviest peer alone (3-4, 300).
  const ViewGraph g = PeerGraph(300, 280, 400);
  const Communities c = ComputeCommunities(g, CommunityOptions());
  CycleScorer b = PeerScorer();
  EXPECT_EQ(TakenPairs(BuildSkeleton(g, c, &b, PeerVote(1))),
            std::set<ImagePair>{ImagePair(2, 5)});
  // A scorer that reports no rotations cannot vote.
  CycleScorer blind = PeerScorer();
  blind.knows_rotations = false;
  EXPECT_EQ(TakenPairs(BuildSkeleton(g, c, &blind, PeerVote(8))),
            std::set<ImagePair>{ImagePair(2, 5)});
}

TEST(SkeletonPeerVote, BridgesRejectedForTheirScoreDoNotVote) {
  // The heaviest bridge, 3-4 (900), turns every cycle by 180 degrees and
  // the verifier rejects it. The tree then meets 1-6 (400, scoring 0.6),
  // whose one peer left, 2-5 (280), agrees: 3-4 would outvote 1-6 if it
  // still voted.
  const ViewGraph g = PeerGraph(900, 400, 280);
  const Communities c = ComputeCommunities(g, CommunityOptions());
  ASSERT_EQ(c.NumCommunities(), 2u);
  CycleScorer scorer;
  scorer.folded = {ImagePair(3, 4)};
  scorer.weak = {ImagePair(3, 4)};
  scorer.middling = {ImagePair(1, 6)};
  const Skeleton s = BuildSkeleton(g, c, &scorer, PeerVote(8));
  EXPECT_EQ(TakenPairs(s), std::set<ImagePair>{ImagePair(1, 6)});
  EXPECT_EQ(s.num_outvoted, 0u);
}

TEST(SkeletonPeerVote, OnlyTheHeaviestPeersVote) {
  // 2-5 (400) against 3-4 (300) and 1-6 (280), which disagree with it, and
  // a third peer 2-6 (250), which agrees (its cycle through 2-5 closes).
  // Two voters: the two heaviest outvote it (580 against 400); were 2-6
  // one of them, they would not (300 or 280 against 400 + 250).
  const ViewGraph g = PeerGraph(300, 280, 400, {{ImagePair(2, 6), 250}});
  const Communities c = ComputeCommunities(g, CommunityOptions());
  ASSERT_EQ(c.NumCommunities(), 2u);
  CycleScorer scorer = PeerScorer();
  scorer.folded = {ImagePair(3, 4), ImagePair(1, 6)};
  const Skeleton s = BuildSkeleton(g, c, &scorer, PeerVote(2));
  EXPECT_EQ(s.num_outvoted, 1u);
  EXPECT_EQ(TakenPairs(s), std::set<ImagePair>{ImagePair(3, 4)});
}

TEST(SkeletonPeerVote, ARefusedBridgeJoinsWhatItsVotersCouldNot) {
  // 2-5 (400, true) is outvoted by 3-4 and 1-6, which turn its cycles and
  // then fail verification: nothing else joins the two communities, so
  // 2-5 does, as the last resort, though there is no fallback.
  const ViewGraph g = PeerGraph(300, 280, 400);
  const Communities c = ComputeCommunities(g, CommunityOptions());
  CycleScorer scorer;
  scorer.middling = {ImagePair(2, 5)};
  scorer.folded = {ImagePair(3, 4), ImagePair(1, 6)};
  scorer.weak = {ImagePair(3, 4), ImagePair(1, 6)};
  const Skeleton s = BuildSkeleton(g, c, &scorer, PeerVote(8));
  EXPECT_EQ(s.num_outvoted, 1u);
  ASSERT_EQ(s.bridges.size(), 1u);
  EXPECT_EQ(s.bridges[0].pair, ImagePair(2, 5));
  EXPECT_EQ(s.bridges[0].role, BridgeRole::kFallback);
}

TEST(SkeletonPeerVote, NegativeSizeIsRejected) {
  SkeletonOptions options;
  options.peer_vote_size = -1;
  EXPECT_THROW(options.Check(), Error);
}

// Scores every bridge 0.9 and reports the consistent share of each pair from
// a table (1 if absent), recording the pairs it was asked about.
class ShareScorer : public BridgeScorer {
 public:
  std::map<ImagePair, double> shares;
  std::vector<ImagePair> share_calls;
  std::string Name() const override { return "share"; }
  std::vector<double> Score(const std::vector<ImagePair>& pairs) override {
    return std::vector<double>(pairs.size(), 0.9);
  }
  double ConsistentShare(const ImagePair& pair) override {
    share_calls.push_back(pair);
    auto it = shares.find(pair);
    return it == shares.end() ? 1.0 : it->second;
  }
};

// One community, a chain 1-2-3-4-5 jumped over by a heavier pair (1, 5) and
// a light one (1, 3); images 1 and 5 are skeletal through the bridges (1, 6)
// and (5, 8) to the communities {6, 7} and {8, 9}.
ViewGraph JumpedChainGraph() {
  return ViewGraph::FromEdges(
      {1, 2, 3, 4, 5, 6, 7, 8, 9},
      {{ImagePair(1, 2), 300}, {ImagePair(2, 3), 310},
       {ImagePair(3, 4), 320}, {ImagePair(4, 5), 330},
       {ImagePair(1, 5), 400}, {ImagePair(1, 3), 100},
       {ImagePair(6, 7), 500}, {ImagePair(8, 9), 500},
       {ImagePair(1, 6), 60},  {ImagePair(5, 8), 60}});
}

std::vector<ImagePair> IntraPairs(const Skeleton& s) {
  std::vector<ImagePair> out;
  for (const ViewGraphEdge& e : s.intra_edges) out.push_back(e.pair);
  return out;
}

TEST(SkeletonIntraEdges, ConsistentSharesKeepTheChainOverAMixedJump) {
  const ViewGraph g = JumpedChainGraph();
  const Communities c = ComputeCommunities(g, CommunityOptions());
  ASSERT_EQ(c.Of(1), c.Of(5));
  ASSERT_NE(c.Of(1), c.Of(6));
  ShareScorer scorer;
  scorer.shares[ImagePair(1, 5)] = 0.3;  // 120 < every link of the chain
  const Skeleton s = BuildSkeleton(g, c, &scorer, SkeletonOptions());
  EXPECT_EQ(IntraPairs(s),
            (std::vector<ImagePair>{ImagePair(1, 2), ImagePair(2, 3),
                                    ImagePair(3, 4), ImagePair(4, 5)}));
  // Lazy and once each: the light jump (1, 3) never reaches the top of the
  // heap while 1 and 3 are apart; the communities {6, 7} and {8, 9} hold
  // one skeletal image each and need no tree.
  std::set<ImagePair> asked(scorer.share_calls.begin(),
                            scorer.share_calls.end());
  EXPECT_EQ(asked.size(), scorer.share_calls.size());
  EXPECT_EQ(asked, (std::set<ImagePair>{ImagePair(1, 2), ImagePair(2, 3),
                                        ImagePair(3, 4), ImagePair(4, 5),
                                        ImagePair(1, 5)}));
}

// ShareScorer that also records each batch of ConsistentShares.
class BatchShareScorer : public ShareScorer {
 public:
  std::vector<std::vector<ImagePair>> batches;
  std::vector<double> ConsistentShares(
      const std::vector<ImagePair>& pairs) override {
    batches.push_back(pairs);
    return ShareScorer::ConsistentShares(pairs);
  }
};

TEST(SkeletonIntraEdges, TheUpperBoundTreeIsAskedInOneBatch) {
  const ViewGraph g = JumpedChainGraph();
  const Communities c = ComputeCommunities(g, CommunityOptions());
  BatchShareScorer scorer;
  scorer.shares[ImagePair(1, 5)] = 0.3;
  const Skeleton s = BuildSkeleton(g, c, &scorer, SkeletonOptions());
  EXPECT_EQ(IntraPairs(s),
            (std::vector<ImagePair>{ImagePair(1, 2), ImagePair(2, 3),
                                    ImagePair(3, 4), ImagePair(4, 5)}));
  // The tree by view-graph weight (1-5, 4-5, 3-4, 2-3) in one batch; only
  // the link that replaces the mixed jump is asked alone afterwards, and
  // no pair twice.
  ASSERT_EQ(scorer.batches.size(), 1u);
  EXPECT_EQ(std::set<ImagePair>(scorer.batches[0].begin(),
                                scorer.batches[0].end()),
            (std::set<ImagePair>{ImagePair(1, 5), ImagePair(2, 3),
                                 ImagePair(3, 4), ImagePair(4, 5)}));
  ASSERT_EQ(scorer.share_calls.size(), 5u);
  EXPECT_EQ(scorer.share_calls.back(), ImagePair(1, 2));
}

// Returns one share too few for a batch.
class ShortBatchScorer : public ShareScorer {
 public:
  std::vector<double> ConsistentShares(
      const std::vector<ImagePair>& pairs) override {
    return std::vector<double>(pairs.empty() ? 0 : pairs.size() - 1, 1.0);
  }
};

TEST(SkeletonIntraEdges, AWrongNumberOfSharesIsAnError) {
  const ViewGraph g = JumpedChainGraph();
  const Communities c = ComputeCommunities(g, CommunityOptions());
  ShortBatchScorer scorer;
  EXPECT_THROW(BuildSkeleton(g, c, &scorer, SkeletonOptions()), Error);
}

TEST(SkeletonIntraEdges, ViewGraphWeightsWhenOffOrWithoutAScorer) {
  const ViewGraph g = JumpedChainGraph();
  const Communities c = ComputeCommunities(g, CommunityOptions());
  ShareScorer scorer;
  scorer.shares[ImagePair(1, 5)] = 0.3;
  SkeletonOptions off;
  off.intra_consistent_weights = false;
  const Skeleton s = BuildSkeleton(g, c, &scorer, off);
  EXPECT_EQ(IntraPairs(s), (std::vector<ImagePair>{ImagePair(1, 5)}));
  EXPECT_TRUE(scorer.share_calls.empty());
  EXPECT_EQ(IntraPairs(BuildSkeleton(g, c, nullptr, SkeletonOptions())),
            (std::vector<ImagePair>{ImagePair(1, 5)}));
}

TEST(SkeletonIntraEdges, ANaNShareCountsAsNone) {
  const ViewGraph g = JumpedChainGraph();
  const Communities c = ComputeCommunities(g, CommunityOptions());
  ShareScorer scorer;
  scorer.shares[ImagePair(1, 5)] = std::nan("");
  EXPECT_EQ(IntraPairs(BuildSkeleton(g, c, &scorer, SkeletonOptions())),
            (std::vector<ImagePair>{ImagePair(1, 2), ImagePair(2, 3),
                                    ImagePair(3, 4), ImagePair(4, 5)}));
}

TEST(SkeletonIntraEdges, AFullShareKeepsTheJump) {
  const ViewGraph g = JumpedChainGraph();
  const Communities c = ComputeCommunities(g, CommunityOptions());
  ShareScorer scorer;
  scorer.shares[ImagePair(1, 5)] = 0.9;  // 360 still outweighs the chain
  EXPECT_EQ(IntraPairs(BuildSkeleton(g, c, &scorer, SkeletonOptions())),
            (std::vector<ImagePair>{ImagePair(1, 5)}));
}

}  // namespace
}  // namespace hisfm
