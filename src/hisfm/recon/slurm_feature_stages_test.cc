#include "hisfm/recon/slurm_feature_stages.h"

#include <gtest/gtest.h>

#include <set>

namespace hisfm {
namespace {

TEST(ExhaustivePairBlocks, HoldEveryPairOnce) {
  for (size_t n : {1, 2, 7, 21}) {
    for (size_t group : {1, 3, 6, 50}) {
      std::set<std::pair<size_t, size_t>> seen;
      size_t count = 0;
      const std::vector<IndexPairs> blocks = ExhaustivePairBlocks(n, group);
      for (const IndexPairs& block : blocks) {
        EXPECT_FALSE(block.empty());
        for (const auto& [i, j] : block) {
          EXPECT_LT(i, j);
          EXPECT_LT(j, n);
          seen.emplace(i, j);
          ++count;
        }
      }
      EXPECT_EQ(count, n * (n - 1) / 2) << n << " " << group;
      EXPECT_EQ(seen.size(), count);
    }
  }
  // 21 images in groups of 6: 4 groups, 10 blocks.
  EXPECT_EQ(ExhaustivePairBlocks(21, 6).size(), 10u);
  EXPECT_EQ(PieceSize(21, 4), 6u);
  EXPECT_EQ(PieceSize(3, 8), 1u);
  EXPECT_EQ(PieceSize(0, 8), 1u);
}

TEST(SequentialPairs, AreColmapsNeighboursAndQuadraticJumps) {
  // overlap 2 without quadratic: direct neighbours.
  EXPECT_EQ(SequentialPairs(4, 2, false),
            (IndexPairs{{0, 1}, {1, 2}, {2, 3}}));
  // overlap 3 with quadratic: +1, +2 and +1, +2, +4.
  const IndexPairs q = SequentialPairs(6, 3, true);
  const std::set<std::pair<size_t, size_t>> s(q.begin(), q.end());
  EXPECT_TRUE(s.count({0, 4}));
  EXPECT_TRUE(s.count({0, 2}));
  EXPECT_FALSE(s.count({0, 3}));
  EXPECT_FALSE(s.count({2, 6}));
  EXPECT_EQ(s.size(), q.size());
  const std::vector<IndexPairs> blocks = CutPairs(q, 4);
  size_t total = 0;
  for (const IndexPairs& b : blocks) {
    EXPECT_LE(b.size(), 4u);
    total += b.size();
  }
  EXPECT_EQ(total, q.size());
}

}  // namespace
}  // namespace hisfm
