#include "hisfm/graph/view_graph.h"

#include <gtest/gtest.h>

#include <set>
#include <vector>

namespace hisfm {
namespace {

// Images 1-4 with mixed weights, and 5-7 with a tie at image 5:
//   1-2 100, 1-3 50, 2-3 80, 2-4 90, 3-4 10, 5-6 20, 5-7 20.
// Places by weight (1 = strongest):
//   image 1: 1-2, 1-3;  image 2: 1-2, 2-4, 2-3;  image 3: 2-3, 1-3, 3-4;
//   image 4: 2-4, 3-4;  image 5: 5-6, 5-7 (the tie: smaller id first).
ViewGraph SmallGraph() {
  return ViewGraph::FromEdges(
      {1, 2, 3, 4, 5, 6, 7},
      {{ImagePair(1, 2), 100}, {ImagePair(1, 3), 50}, {ImagePair(2, 3), 80},
       {ImagePair(2, 4), 90}, {ImagePair(3, 4), 10}, {ImagePair(5, 6), 20},
       {ImagePair(5, 7), 20}});
}

TEST(ViewGraph, FromEdgesMergesDuplicatesAndDropsUnknownImages) {
  const ViewGraph g = ViewGraph::FromEdges(
      {1, 2, 3}, {{ImagePair(1, 2), 30}, {ImagePair(1, 2), 10},
                  {ImagePair(2, 9), 50}});
  EXPECT_EQ(g.NumImages(), 3u);
  ASSERT_EQ(g.NumEdges(), 1u);
  EXPECT_EQ(g.Weight(2, 1), 30u);
  EXPECT_EQ(g.Weight(1, 3), 0u);
}

TEST(ViewGraph, StrongestNeighboursByWeightThenId) {
  const ViewGraph g = SmallGraph();
  EXPECT_EQ(StrongestNeighbours(g, 2, 2), (std::vector<ImageId>{1, 4}));
  EXPECT_EQ(StrongestNeighbours(g, 2, 5), (std::vector<ImageId>{1, 4, 3}));
  EXPECT_EQ(StrongestNeighbours(g, 2, 2, /*exclude=*/1),
            (std::vector<ImageId>{4, 3}));
  EXPECT_EQ(StrongestNeighbours(g, 5, 1), (std::vector<ImageId>{6}));
  EXPECT_TRUE(StrongestNeighbours(g, 42, 3).empty());
}

TEST(ViewGraph, MutualRankIsTheWorsePlaceOfTheTwoImages) {
  const ViewGraph g = SmallGraph();
  // Edges() order: 1-2, 1-3, 2-3, 2-4, 3-4, 5-6, 5-7.
  EXPECT_EQ(MutualRanks(g), (std::vector<uint32_t>{1, 2, 3, 2, 3, 1, 2}));
}

TEST(ViewGraph, PairsOfMutualRankAtMost) {
  const ViewGraph g = SmallGraph();
  EXPECT_TRUE(PairsOfMutualRankAtMost(g, 0).empty());
  EXPECT_EQ(PairsOfMutualRankAtMost(g, 1),
            (std::set<ImagePair>{ImagePair(1, 2), ImagePair(5, 6)}));
  EXPECT_EQ(PairsOfMutualRankAtMost(g, 2),
            (std::set<ImagePair>{ImagePair(1, 2), ImagePair(1, 3),
                                 ImagePair(2, 4), ImagePair(5, 6),
                                 ImagePair(5, 7)}));
  EXPECT_EQ(PairsOfMutualRankAtMost(g, 3).size(), g.NumEdges());
}

}  // namespace
}  // namespace hisfm
