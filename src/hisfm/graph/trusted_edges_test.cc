#include "hisfm/graph/trusted_edges.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <memory>
#include <set>

#include "hisfm/util/error.h"

namespace hisfm {
namespace {

constexpr int kNumImages = 12;
constexpr int kPeriod = 6;

// A street of kNumImages views along one facade whose pattern repeats every
// kPeriod views: true pairs join neighbours one and two views apart, the
// doppelgangers join views kPeriod apart. Images 3 and 4 see their
// doppelganger more strongly than any true neighbour, so their strongest
// pairs (their community edges) are doppelgangers.
ViewGraph RepeatedStreet() {
  std::vector<ImageId> images;
  std::vector<ViewGraphEdge> edges;
  for (int i = 1; i <= kNumImages; ++i) {
    images.push_back(ImageId(i));
    if (i + 1 <= kNumImages) {
      edges.push_back({ImagePair(i, i + 1), uint32_t(200 + 3 * i)});
    }
    if (i + 2 <= kNumImages) {
      edges.push_back({ImagePair(i, i + 2), uint32_t(120 + i)});
    }
    if (i + kPeriod <= kNumImages) {
      const bool strong = i == 3 || i == 4;
      edges.push_back(
          {ImagePair(i, i + kPeriod), uint32_t(strong ? 400 + i : 90 + i)});
    }
  }
  return ViewGraph::FromEdges(images, edges);
}

bool IsDoppelganger(const ImagePair& p) {
  return p.image_id2 - p.image_id1 == kPeriod;
}

// Scores doppelgangers 0 and true pairs 1; counts the calls per pair over
// every scorer the factory makes.
struct LabelScorer : BridgeScorer {
  explicit LabelScorer(std::map<ImagePair, int>* calls) : calls(calls) {}
  std::map<ImagePair, int>* calls;
  std::string Name() const override { return "labels"; }
  std::vector<double> Score(const std::vector<ImagePair>& pairs) override {
    std::vector<double> s;
    for (const ImagePair& p : pairs) {
      ++(*calls)[p];
      s.push_back(IsDoppelganger(p) ? 0.0 : 1.0);
    }
    return s;
  }
};

ScorerFactory LabelFactory(std::map<ImagePair, int>* calls) {
  return [calls](const Communities&) -> std::unique_ptr<BridgeScorer> {
    return std::make_unique<LabelScorer>(calls);
  };
}

size_t CountDoppelgangers(const std::vector<ImagePair>& pairs) {
  return std::count_if(pairs.begin(), pairs.end(), IsDoppelganger);
}

// True if both doppelganger community edges are among `pairs` (sorted).
bool HoldsBothStrongDoppelgangers(const std::vector<ImagePair>& pairs) {
  return std::binary_search(pairs.begin(), pairs.end(), ImagePair(3, 9)) &&
         std::binary_search(pairs.begin(), pairs.end(), ImagePair(4, 10));
}

TEST(TrustedEdges, PaperHierarchyTrustsDoppelgangerCommunityEdges) {
  // The premise of the other tests: Algorithm 1 verifies the bridges only,
  // so the doppelganger community edges stay in its hierarchy.
  std::map<ImagePair, int> calls;
  const Hierarchy h =
      BuildHierarchy(RepeatedStreet(), LabelFactory(&calls), {});
  EXPECT_TRUE(HoldsBothStrongDoppelgangers(TrustedEdges(h)));
  std::set<ImagePair> community_edges;
  for (const ViewGraphEdge& e : h.communities.top_k_edges) {
    community_edges.insert(e.pair);
  }
  for (const auto& [pair, n] : calls) {
    EXPECT_FALSE(community_edges.count(pair))
        << "community edge " << pair.image_id1 << "-" << pair.image_id2
        << " was scored";
  }
}

TEST(TrustedEdges, RejectedEdgesLeaveTheHierarchyAndEachPairIsScoredOnce) {
  const ViewGraph street = RepeatedStreet();
  std::map<ImagePair, int> calls;
  const JudgedHierarchy j = BuildHierarchyJudgingTrustedEdges(
      street, LabelFactory(&calls), {}, TrustedEdgeOptions());
  EXPECT_EQ(CountDoppelgangers(j.hierarchy.Edges()), 0u);
  EXPECT_EQ(j.num_unresolved, 0u);
  EXPECT_GE(j.rounds, 2);
  std::set<ImagePair> rejected;
  for (const RejectedTrustedEdge& r : j.rejected) {
    EXPECT_TRUE(IsDoppelganger(r.pair));
    EXPECT_EQ(r.score, 0.0);
    EXPECT_EQ(r.weight, street.Weight(r.pair.image_id1, r.pair.image_id2));
    EXPECT_LT(r.round, j.rounds);
    EXPECT_EQ(j.graph.Weight(r.pair.image_id1, r.pair.image_id2), 0u);
    rejected.insert(r.pair);
  }
  EXPECT_TRUE(rejected.count(ImagePair(3, 9)));
  EXPECT_TRUE(rejected.count(ImagePair(4, 10)));
  for (const auto& [pair, n] : calls) EXPECT_EQ(n, 1) << "scored twice";
  EXPECT_EQ(j.scores.size(), calls.size());
  // Bridges are scored too; the trusted edges of the final round are among
  // the scored ones.
  EXPECT_LE(j.num_scored, calls.size());
  EXPECT_GE(j.num_scored, TrustedEdges(j.hierarchy).size());
  // The true chain joins every image into one component.
  ASSERT_EQ(j.hierarchy.components.size(), 1u);
  EXPECT_EQ(j.hierarchy.components[0].images.size(), size_t(kNumImages));
}

TEST(TrustedEdges, RoundLimitKeepsWhatTheLastRoundRejects) {
  TrustedEdgeOptions one;
  one.max_rounds = 1;
  std::map<ImagePair, int> calls;
  const JudgedHierarchy j = BuildHierarchyJudgingTrustedEdges(
      RepeatedStreet(), LabelFactory(&calls), {}, one);
  EXPECT_EQ(j.rounds, 1);
  EXPECT_TRUE(j.rejected.empty());
  EXPECT_TRUE(HoldsBothStrongDoppelgangers(TrustedEdges(j.hierarchy)));
  EXPECT_EQ(j.num_unresolved, CountDoppelgangers(TrustedEdges(j.hierarchy)));
}

TEST(TrustedEdges, SilentScoresAndFreeScorersRejectNothing) {
  std::map<ImagePair, int> calls;
  const JudgedHierarchy silent = BuildHierarchyJudgingTrustedEdges(
      RepeatedStreet(), LabelFactory(&calls), {}, TrustedEdgeOptions(),
      [](const ImagePair& p) { return !IsDoppelganger(p); });
  EXPECT_TRUE(silent.rejected.empty());
  EXPECT_EQ(silent.rounds, 1);
  EXPECT_TRUE(HoldsBothStrongDoppelgangers(TrustedEdges(silent.hierarchy)));

  const JudgedHierarchy free = BuildHierarchyJudgingTrustedEdges(
      RepeatedStreet(),
      [](const Communities&) -> std::unique_ptr<BridgeScorer> {
        return std::make_unique<AcceptAllScorer>();
      },
      {}, TrustedEdgeOptions());
  EXPECT_EQ(free.rounds, 1);
  EXPECT_EQ(free.num_scored, 0u);
  const JudgedHierarchy none = BuildHierarchyJudgingTrustedEdges(
      RepeatedStreet(), nullptr, {}, TrustedEdgeOptions());
  EXPECT_EQ(none.rounds, 1);
  EXPECT_EQ(none.num_scored, 0u);
  EXPECT_EQ(none.hierarchy.Edges(),
            BuildHierarchy(RepeatedStreet(), nullptr, {}).Edges());
}

TEST(TrustedEdges, ThresholdDecidesRejection) {
  // Every pair scores 0.5: rejected below a threshold of 0.6, kept at 0.5.
  struct Half : BridgeScorer {
    std::string Name() const override { return "half"; }
    std::vector<double> Score(const std::vector<ImagePair>& p) override {
      return std::vector<double>(p.size(), 0.5);
    }
  };
  auto factory = [](const Communities&) -> std::unique_ptr<BridgeScorer> {
    return std::make_unique<Half>();
  };
  TrustedEdgeOptions kept;
  kept.threshold = 0.5;
  EXPECT_TRUE(BuildHierarchyJudgingTrustedEdges(RepeatedStreet(), factory, {},
                                                kept)
                  .rejected.empty());
  TrustedEdgeOptions strict;
  strict.threshold = 0.6;
  strict.max_rounds = 2;
  const JudgedHierarchy j =
      BuildHierarchyJudgingTrustedEdges(RepeatedStreet(), factory, {}, strict);
  EXPECT_FALSE(j.rejected.empty());
  for (const RejectedTrustedEdge& r : j.rejected) EXPECT_EQ(r.score, 0.5);
}

TEST(TrustedEdges, CheckRejectsOutOfRangeOptions) {
  TrustedEdgeOptions o;
  EXPECT_NO_THROW(o.Check());
  o.threshold = -0.1;
  EXPECT_THROW(o.Check(), Error);
  o.threshold = 1.1;
  EXPECT_THROW(o.Check(), Error);
  o.threshold = 0.5;
  o.max_rounds = 0;
  EXPECT_THROW(o.Check(), Error);
}

}  // namespace
}  // namespace hisfm
