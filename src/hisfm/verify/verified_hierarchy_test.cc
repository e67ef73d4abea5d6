#include "hisfm/verify/verified_hierarchy.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <map>
#include <set>
#include <string>
#include <unordered_map>
#include <vector>

#include "hisfm/util/error.h"
#include "hisfm/verify/street_test_scene.h"
#include "hisfm/verify/view_graph_reader.h"

namespace hisfm {
namespace {

bool Contains(const std::vector<ImagePair>& sorted, const ImagePair& p) {
  return std::binary_search(sorted.begin(), sorted.end(), p);
}

// What every verified hierarchy promises, whatever the options.
void ExpectVerifiedHierarchy(const ViewGraph& input,
                             MultiViewVerifier& verifier,
                             const VerifiedHierarchyOptions& options,
                             const VerifiedHierarchy& v) {
  EXPECT_GE(v.rounds, 1);
  EXPECT_LE(v.rounds, options.trusted_edges.max_rounds);
  EXPECT_EQ(v.graph.Images(), input.Images());
  const std::vector<ImagePair> edges = v.hierarchy.Edges();
  EXPECT_TRUE(std::is_sorted(edges.begin(), edges.end()));
  std::set<ImagePair> rejected;
  for (const RejectedTrustedEdge& r : v.rejected) {
    EXPECT_TRUE(rejected.insert(r.pair).second) << "rejected twice";
    // Rejected trusted edges are gone from the final graph and hierarchy.
    EXPECT_EQ(v.graph.Weight(r.pair.image_id1, r.pair.image_id2), 0u);
    EXPECT_FALSE(Contains(edges, r.pair));
    EXPECT_LT(r.score, options.trusted_edges.threshold);
    EXPECT_DOUBLE_EQ(r.score, verifier.ScoreOf(r.pair));
    EXPECT_EQ(r.weight, input.Weight(r.pair.image_id1, r.pair.image_id2));
    // Each rejection is followed by a rebuild.
    EXPECT_GE(r.round, 0);
    EXPECT_LT(r.round + 1, v.rounds);
  }
  // The final graph is the input without the rejected edges.
  EXPECT_EQ(v.graph.NumEdges() + rejected.size(), input.NumEdges());
  for (const ViewGraphEdge& e : v.graph.Edges()) {
    EXPECT_EQ(e.weight, input.Weight(e.pair.image_id1, e.pair.image_id2));
  }
  // Trusted edges left below the threshold are counted as unresolved,
  // except those kept for their mutual rank (trusted_keep_rank).
  const std::set<ImagePair> kept_by_rank = PairsOfMutualRankAtMost(
      input, static_cast<uint32_t>(options.trusted_keep_rank));
  size_t failing = 0;
  for (const ImagePair& p : TrustedEdges(v.hierarchy)) {
    EXPECT_GT(v.graph.Weight(p.image_id1, p.image_id2), 0u);
    failing += verifier.ScoreOf(p) < options.trusted_edges.threshold &&
               !kept_by_rank.count(p);
  }
  for (const RejectedTrustedEdge& r : v.rejected) {
    EXPECT_FALSE(kept_by_rank.count(r.pair)) << "kept by its rank";
  }
  EXPECT_EQ(failing, v.num_unresolved);
  if (v.rounds < options.trusted_edges.max_rounds) {
    EXPECT_EQ(v.num_unresolved, 0u);
  }
  // Support edges: at most support_edges per image of each end's strongest,
  // scoring at least support_threshold, inside a component.
  std::map<ImageId, size_t> component_of;
  for (size_t c = 0; c < v.hierarchy.components.size(); ++c) {
    for (const ImageId id : v.hierarchy.components[c].images) {
      component_of[id] = c;
    }
  }
  EXPECT_LE(v.hierarchy.support_edges.size(),
            options.support_edges * v.graph.NumImages());
  for (const ViewGraphEdge& e : v.hierarchy.support_edges) {
    EXPECT_GE(verifier.ScoreOf(e.pair), options.support_threshold);
    EXPECT_GT(v.graph.Weight(e.pair.image_id1, e.pair.image_id2), 0u);
    ASSERT_TRUE(component_of.count(e.pair.image_id1));
    ASSERT_TRUE(component_of.count(e.pair.image_id2));
    const size_t c = component_of.at(e.pair.image_id1);
    EXPECT_EQ(c, component_of.at(e.pair.image_id2));
    const std::vector<ImagePair>& ce = v.hierarchy.components[c].edges;
    EXPECT_TRUE(Contains(ce, e.pair));
    EXPECT_TRUE(Contains(edges, e.pair));
  }
  // Reserve edges: inside a component, not in the hierarchy, scoring at
  // least the bridges' threshold and below the support threshold.
  const double tau = HierarchyOptions().skeleton.verify_threshold;
  for (const ViewGraphEdge& e : v.reserve_edges) {
    EXPECT_FALSE(Contains(edges, e.pair));
    const double score = verifier.ScoreOf(e.pair);
    EXPECT_GE(score, tau);
    EXPECT_LT(score, options.support_threshold);
  }
  // Cleaned inliers: one entry per edge of the hierarchy and per reserve
  // edge, a subset of the pair's inliers.
  std::vector<ImagePair> used = edges;
  for (const ViewGraphEdge& e : v.reserve_edges) used.push_back(e.pair);
  if (!options.clean_inliers) {
    EXPECT_TRUE(v.inliers.empty());
    EXPECT_EQ(v.num_inliers_before, 0u);
    EXPECT_EQ(v.num_inliers_after, 0u);
    return;
  }
  EXPECT_EQ(v.inliers.size(), used.size());
  size_t before = 0, after = 0;
  for (const ImagePair& p : used) {
    auto it = v.inliers.find(p);
    ASSERT_NE(it, v.inliers.end());
    const std::vector<FeatureMatch>& stored =
        verifier.cache().Pair(p.image_id1, p.image_id2)->matches;
    std::set<std::pair<Point2DIdx, Point2DIdx>> all;
    for (const FeatureMatch& m : stored) all.insert({m.idx1, m.idx2});
    for (const FeatureMatch& m : it->second) {
      EXPECT_TRUE(all.count({m.idx1, m.idx2}));
    }
    before += stored.size();
    after += it->second.size();
  }
  EXPECT_EQ(v.num_inliers_before, before);
  EXPECT_EQ(v.num_inliers_after, after);
  EXPECT_LE(after, before);
}

// The repeated test street (16 photos, seed 1; street_test_scene.h).
TEST(VerifiedHierarchy, DefaultOptionsRejectDoppelgangerTrustedEdges) {
  street_test::Opened street(1, 16);
  MultiViewVerifier verifier(street.db, street.graph);
  const VerifiedHierarchyOptions options;
  const VerifiedHierarchy v =
      BuildVerifiedHierarchy(street.graph, verifier, HierarchyOptions(), options);
  ExpectVerifiedHierarchy(street.graph, verifier, options, v);
  // The street's strongest pairs include doppelgangers; the ones rejected
  // at the default threshold are mostly doppelgangers (RANSAC makes the
  // exact set depend on the compiler's floating point: the clang sanitizer
  // build rejected one true pair more than gcc), and a rebuild followed.
  ASSERT_FALSE(v.rejected.empty());
  EXPECT_GE(v.rounds, 2);
  size_t num_doppelgangers = 0;
  for (const RejectedTrustedEdge& r : v.rejected) {
    num_doppelgangers += street.scene.shift.at(r.pair) != 0;
  }
  EXPECT_GE(3 * num_doppelgangers, 2 * v.rejected.size())
      << num_doppelgangers << " of " << v.rejected.size()
      << " rejected trusted edges are doppelgangers";
  // One model; support edges were added and the cleaning dropped inliers.
  EXPECT_EQ(v.hierarchy.components.size(), 1u);
  EXPECT_FALSE(v.hierarchy.support_edges.empty());
  EXPECT_LT(v.num_inliers_after, v.num_inliers_before);
}

// Trusted edges among the strongest pairs of both their images are kept
// whatever their score (VerifiedHierarchyOptions::trusted_keep_rank).
TEST(VerifiedHierarchy, KeepRankKeepsMutuallyStrongestPairs) {
  street_test::Opened street(1, 16);
  MultiViewVerifier verifier(street.db, street.graph);
  const std::vector<uint32_t> ranks = MutualRanks(street.graph);
  std::map<ImagePair, uint32_t> rank_of;
  for (size_t e = 0; e < ranks.size(); ++e) {
    rank_of[street.graph.Edges()[e].pair] = ranks[e];
  }
  // The smallest mutual rank among the edges rejected when every trusted
  // edge is judged.
  VerifiedHierarchyOptions all;
  all.trusted_keep_rank = 0;
  const VerifiedHierarchy judged =
      BuildVerifiedHierarchy(street.graph, verifier, HierarchyOptions(), all);
  ExpectVerifiedHierarchy(street.graph, verifier, all, judged);
  ASSERT_FALSE(judged.rejected.empty());
  uint32_t lowest = UINT32_MAX;
  for (const RejectedTrustedEdge& r : judged.rejected) {
    lowest = std::min(lowest, rank_of.at(r.pair));
  }
  // Keeping that rank keeps those edges: no edge of that rank or less is
  // rejected, and an edge rejected before for its low score is now part of
  // the hierarchy.
  VerifiedHierarchyOptions keep;
  keep.trusted_keep_rank = static_cast<int>(lowest);
  const VerifiedHierarchy kept =
      BuildVerifiedHierarchy(street.graph, verifier, HierarchyOptions(), keep);
  ExpectVerifiedHierarchy(street.graph, verifier, keep, kept);
  for (const RejectedTrustedEdge& r : kept.rejected) {
    EXPECT_GT(rank_of.at(r.pair), lowest);
  }
  const std::vector<ImagePair> trusted = TrustedEdges(kept.hierarchy);
  const std::set<ImagePair> trusted_now(trusted.begin(), trusted.end());
  size_t spared_in_hierarchy = 0;
  for (const RejectedTrustedEdge& r : judged.rejected) {
    if (rank_of.at(r.pair) <= lowest && trusted_now.count(r.pair)) {
      EXPECT_LT(verifier.ScoreOf(r.pair), keep.trusted_edges.threshold);
      ++spared_in_hierarchy;
    }
  }
  EXPECT_GE(spared_in_hierarchy, 1u);
}

TEST(VerifiedHierarchy, StricterThresholdsAndRoundLimits) {
  street_test::Opened street(1, 16);
  MultiViewVerifier verifier(street.db, street.graph);
  VerifiedHierarchyOptions options;
  options.trusted_edges.threshold = 0.8;
  options.trusted_keep_rank = 0;
  const VerifiedHierarchy v =
      BuildVerifiedHierarchy(street.graph, verifier, HierarchyOptions(), options);
  ExpectVerifiedHierarchy(street.graph, verifier, options, v);
  ASSERT_GE(v.rounds, 2);
  // Edges rejected in later rounds were trusted only after a rebuild.
  EXPECT_GT(v.rejected.back().round, 0);
  EXPECT_TRUE(std::is_sorted(
      v.rejected.begin(), v.rejected.end(),
      [](const RejectedTrustedEdge& a, const RejectedTrustedEdge& b) {
        return a.round < b.round;
      }));

  // One round: the failing trusted edges are kept and counted.
  VerifiedHierarchyOptions one = options;
  one.trusted_edges.max_rounds = 1;
  const VerifiedHierarchy v1 =
      BuildVerifiedHierarchy(street.graph, verifier, HierarchyOptions(), one);
  ExpectVerifiedHierarchy(street.graph, verifier, one, v1);
  EXPECT_EQ(v1.rounds, 1);
  EXPECT_TRUE(v1.rejected.empty());
  EXPECT_GT(v1.num_unresolved, 0u);
  EXPECT_EQ(v1.graph.NumEdges(), street.graph.NumEdges());

  // A trusted threshold of 0 rejects nothing.
  VerifiedHierarchyOptions none = options;
  none.trusted_edges.threshold = 0;
  const VerifiedHierarchy v0 =
      BuildVerifiedHierarchy(street.graph, verifier, HierarchyOptions(), none);
  ExpectVerifiedHierarchy(street.graph, verifier, none, v0);
  EXPECT_EQ(v0.rounds, 1);
  EXPECT_TRUE(v0.rejected.empty());

  // Without support edges and cleaning.
  VerifiedHierarchyOptions bare = options;
  bare.support_edges = 0;
  bare.clean_inliers = false;
  const VerifiedHierarchy vb =
      BuildVerifiedHierarchy(street.graph, verifier, HierarchyOptions(), bare);
  ExpectVerifiedHierarchy(street.graph, verifier, bare, vb);
  EXPECT_TRUE(vb.hierarchy.support_edges.empty());

  // A higher support threshold never adds more support edges.
  VerifiedHierarchyOptions picky = options;
  picky.support_threshold = 0.95;
  const VerifiedHierarchy vp =
      BuildVerifiedHierarchy(street.graph, verifier, HierarchyOptions(), picky);
  ExpectVerifiedHierarchy(street.graph, verifier, picky, vp);
  EXPECT_LE(vp.hierarchy.support_edges.size(), v.hierarchy.support_edges.size());
}

TEST(VerifiedHierarchy, AddSupportEdgesRespectsCountAndThreshold) {
  street_test::Opened street(2, 10);
  MultiViewVerifier verifier(street.db, street.graph);
  const Hierarchy base =
      BuildHierarchy(street.graph, &verifier, HierarchyOptions());
  ASSERT_FALSE(base.components.empty());
  const std::vector<ImagePair> base_edges = base.Edges();
  Hierarchy h = base;
  AddSupportEdges(street.graph, verifier, 0, 0.0, &h);
  EXPECT_TRUE(h.support_edges.empty());
  h = base;
  AddSupportEdges(street.graph, verifier, 3, 1.01, &h);  // nothing scores > 1
  EXPECT_TRUE(h.support_edges.empty());
  h = base;
  AddSupportEdges(street.graph, verifier, 3, 0.0, &h);  // every pair passes
  ASSERT_FALSE(h.support_edges.empty());
  std::set<ImagePair> added;
  for (const ViewGraphEdge& e : h.support_edges) {
    EXPECT_TRUE(added.insert(e.pair).second);
    EXPECT_FALSE(Contains(base_edges, e.pair)) << "already an edge";
    // Among the 3 strongest pairs of one of its images.
    const auto is_top3 = [&](ImageId a, ImageId b) {
      const std::vector<ImageId> top = StrongestNeighbours(street.graph, a, 3);
      return std::find(top.begin(), top.end(), b) != top.end();
    };
    EXPECT_TRUE(is_top3(e.pair.image_id1, e.pair.image_id2) ||
                is_top3(e.pair.image_id2, e.pair.image_id1));
  }
  // Every image's 3 strongest pairs inside its component are now edges.
  const std::vector<ImagePair> edges = h.Edges();
  for (const HierarchyComponent& c : h.components) {
    for (const ImageId id : c.images) {
      for (const ImageId other : StrongestNeighbours(street.graph, id, 3)) {
        if (!std::binary_search(c.images.begin(), c.images.end(), other)) {
          continue;
        }
        EXPECT_TRUE(Contains(edges, ImagePair(std::min(id, other),
                                              std::max(id, other))));
      }
    }
    EXPECT_TRUE(std::is_sorted(c.edges.begin(), c.edges.end()));
    EXPECT_TRUE(std::is_sorted(c.skeleton_edges.begin(), c.skeleton_edges.end()));
  }
}

// A plug-in verifier's scores: every pair scores by its images' id
// difference (1 or 2: 0.9, 3: 0.6, otherwise 0.1).
class DistanceScorer : public BridgeScorer {
 public:
  std::vector<double> Score(const std::vector<ImagePair>& pairs) override {
    std::vector<double> out;
    for (const ImagePair& p : pairs) {
      const ImageId d = p.image_id2 - p.image_id1;
      out.push_back(d <= 2 ? 0.9 : d == 3 ? 0.6 : 0.1);
    }
    return out;
  }
  std::string Name() const override { return "distance"; }
};

TEST(VerifiedHierarchy, AddSupportEdgesTakesAnyScorer) {
  street_test::Opened street(2, 10);
  DistanceScorer scorer;
  const Hierarchy base =
      BuildHierarchy(street.graph, &scorer, HierarchyOptions());
  ASSERT_FALSE(base.components.empty());
  Hierarchy h = base;
  std::vector<ViewGraphEdge> reserve;
  AddSupportEdges(street.graph, scorer, 3, 0.8, &h, &reserve, 0.5);
  const std::vector<ImagePair> base_edges = base.Edges();
  for (const ViewGraphEdge& e : h.support_edges) {
    EXPECT_LE(e.pair.image_id2 - e.pair.image_id1, 2u) << "scores 0.9";
    EXPECT_FALSE(Contains(base_edges, e.pair));
  }
  for (const ViewGraphEdge& e : reserve) {
    EXPECT_EQ(e.pair.image_id2 - e.pair.image_id1, 3u) << "scores 0.6";
    EXPECT_FALSE(Contains(h.Edges(), e.pair)) << "reserve edges are not used";
  }
  EXPECT_FALSE(h.support_edges.empty());
}

TEST(VerifiedHierarchy, CleanInliersKeepsASubsetOfEachPairsMatches) {
  street_test::Opened street(2, 10);
  MultiViewVerifier verifier(street.db, street.graph);
  std::vector<ImagePair> pairs;
  for (const ViewGraphEdge& e : street.graph.Edges()) pairs.push_back(e.pair);
  std::unordered_map<ImagePair, std::vector<FeatureMatch>, ImagePairHash>
      inliers;
  size_t before = 0;
  size_t after = 0;
  CleanInliers(pairs, verifier, &inliers, &before, &after);
  ASSERT_EQ(inliers.size(), pairs.size());
  size_t total_before = 0;
  size_t total_after = 0;
  size_t judged_and_cut = 0;
  for (const ImagePair& p : pairs) {
    const std::vector<FeatureMatch>& all =
        verifier.cache().Pair(p.image_id1, p.image_id2)->matches;
    const std::vector<FeatureMatch>& kept = inliers.at(p);
    total_before += all.size();
    total_after += kept.size();
    EXPECT_LE(kept.size(), all.size());
    for (const FeatureMatch& m : kept) {
      EXPECT_NE(std::find_if(all.begin(), all.end(),
                             [&](const FeatureMatch& a) {
                               return a.idx1 == m.idx1 &&
                                      a.idx2 == m.idx2;
                             }),
                all.end());
    }
    judged_and_cut += kept.size() < all.size();
  }
  EXPECT_EQ(before, total_before);
  EXPECT_EQ(after, total_after);
  // The street's doppelganger pairs lose the matches of the wrong geometry.
  EXPECT_GT(judged_and_cut, 0u);
  EXPECT_LT(after, before);
}

TEST(VerifiedHierarchy, TrustedEdgesAreTopKIntraAndLeafEdges) {
  Hierarchy h;
  h.communities.top_k_edges = {{ImagePair(1, 2), 100}, {ImagePair(3, 4), 90}};
  h.skeleton.intra_edges = {{ImagePair(1, 2), 100}, {ImagePair(2, 5), 40}};
  h.leaf_edges = {{ImagePair(6, 7), 30}, {ImagePair(1, 6), 20}};
  BridgeRecord bridge;
  bridge.pair = ImagePair(2, 3);
  h.skeleton.bridges.push_back(bridge);
  h.support_edges = {{ImagePair(4, 5), 10}};
  const std::vector<ImagePair> trusted = TrustedEdges(h);
  EXPECT_EQ(trusted, (std::vector<ImagePair>{ImagePair(1, 2), ImagePair(1, 6),
                                             ImagePair(2, 5), ImagePair(3, 4),
                                             ImagePair(6, 7)}));
}

TEST(VerifiedHierarchyOptions, CheckRejectsOutOfRangeValues) {
  EXPECT_NO_THROW(VerifiedHierarchyOptions().Check());
  auto expect_throw = [](auto modify) {
    VerifiedHierarchyOptions o;
    modify(o);
    EXPECT_THROW(o.Check(), Error);
  };
  expect_throw([](VerifiedHierarchyOptions& o) { o.trusted_edges.max_rounds = 0; });
  expect_throw([](VerifiedHierarchyOptions& o) { o.trusted_edges.threshold = -0.1; });
  expect_throw([](VerifiedHierarchyOptions& o) { o.trusted_edges.threshold = 1.1; });
  expect_throw([](VerifiedHierarchyOptions& o) { o.support_edges = -1; });
  expect_throw([](VerifiedHierarchyOptions& o) { o.trusted_keep_rank = -1; });
  expect_throw([](VerifiedHierarchyOptions& o) { o.support_threshold = -0.5; });
  expect_throw([](VerifiedHierarchyOptions& o) { o.support_threshold = 2; });
  // The boundaries are valid.
  VerifiedHierarchyOptions o;
  o.trusted_edges.threshold = 1;
  o.support_threshold = 0;
  o.support_edges = 0;
  o.trusted_edges.max_rounds = 1;
  EXPECT_NO_THROW(o.Check());
}

TEST(VerifiedHierarchyOptions, BuildRefusesInvalidOptions) {
  // Checked before any pair is scored.
  TempDir dir("hisfm-verified-hierarchy");
  street_test::Write(dir / "database.db", {4, true, 1});
  const Database db(dir / "database.db");
  const ViewGraph graph = ReadViewGraph(db, 15);
  MultiViewVerifier verifier(db, graph);
  VerifiedHierarchyOptions options;
  options.trusted_edges.max_rounds = 0;
  EXPECT_THROW(
      BuildVerifiedHierarchy(graph, verifier, HierarchyOptions(), options),
      Error);
  EXPECT_EQ(verifier.NumEvaluated(), 0u);
}

}  // namespace
}  // namespace hisfm
