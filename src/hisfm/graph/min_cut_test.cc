#include "hisfm/graph/min_cut.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <random>
#include <set>

namespace hisfm {
namespace {

using Edges = std::vector<std::pair<size_t, size_t>>;

// Minimum cut of a small multigraph over `n` vertices, by enumerating all
// bipartitions.
size_t BruteForceMinCut(size_t n, const Edges& edges) {
  size_t best = edges.size() + 1;
  for (uint64_t mask = 1; mask + 1 < (uint64_t(1) << n); ++mask) {
    if (!(mask & 1)) continue;  // Each cut once.
    size_t cut = 0;
    for (const auto& [a, b] : edges) {
      cut += ((mask >> a) & 1) != ((mask >> b) & 1);
    }
    best = std::min(best, cut);
  }
  return best;
}

// Edges crossing the cut; fails the test unless the side is a proper subset.
size_t Crossing(size_t n, const Edges& edges, const MinCut& cut) {
  const std::set<size_t> side(cut.side.begin(), cut.side.end());
  EXPECT_EQ(side.size(), cut.side.size());
  EXPECT_FALSE(side.empty());
  EXPECT_LT(side.size(), n);
  size_t crossing = 0;
  for (const auto& [a, b] : edges) crossing += side.count(a) != side.count(b);
  return crossing;
}

// `m` random edges over n vertices, parallel edges allowed.
Edges RandomMultigraph(size_t n, size_t m, std::mt19937* rng) {
  Edges edges;
  while (edges.size() < m) {
    const size_t a = (*rng)() % n, b = (*rng)() % n;
    if (a != b) edges.push_back({a, b});
  }
  return edges;
}

TEST(MinCut, MatchesBruteForce) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 300; ++trial) {
    const size_t n = 2 + rng() % 11;
    // From sparse (often disconnected) to dense.
    const size_t m = rng() % (n * (1 + trial % 5));
    const Edges edges = RandomMultigraph(n, m, &rng);
    const MinCut cut = GlobalMinCut(n, edges);
    EXPECT_EQ(cut.value, BruteForceMinCut(n, edges)) << "trial " << trial;
    EXPECT_EQ(Crossing(n, edges, cut), cut.value) << "trial " << trial;
  }
}

TEST(MinCut, StopsProvingAtEnough) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 300; ++trial) {
    const size_t n = 2 + rng() % 11;
    const Edges edges = RandomMultigraph(n, rng() % (4 * n), &rng);
    const size_t enough = 1 + rng() % 6;
    const size_t exact = BruteForceMinCut(n, edges);
    const MinCut cut = GlobalMinCut(n, edges, enough);
    if (exact < enough) {
      EXPECT_EQ(cut.value, exact) << "trial " << trial;
    } else {
      EXPECT_GE(cut.value, enough) << "trial " << trial;
    }
    EXPECT_EQ(Crossing(n, edges, cut), cut.value) << "trial " << trial;
  }
}

TEST(MinCut, FindsPlantedCutBetweenLargeClusters) {
  std::mt19937 rng(3);
  const size_t half = 300, n = 2 * half;
  for (size_t planted = 0; planted < 4; ++planted) {
    // Each cluster: a ring (so every vertex has degree >= 2) plus random
    // chords, every vertex well above `planted` edges; vertices of the two
    // clusters are interleaved so the side is not a prefix.
    Edges edges;
    for (size_t c = 0; c < 2; ++c) {
      auto vertex = [&](size_t i) { return 2 * (i % half) + c; };
      for (size_t i = 0; i < half; ++i) {
        for (size_t r = 0; r < 4; ++r) edges.push_back({vertex(i), vertex(i + 1)});
        for (size_t r = 0; r < 4; ++r) {
          edges.push_back({vertex(i), vertex(i + 1 + rng() % (half - 1))});
        }
      }
    }
    for (size_t k = 0; k < planted; ++k) {
      edges.push_back({2 * (rng() % half), 2 * (rng() % half) + 1});
    }
    std::shuffle(edges.begin(), edges.end(), rng);
    const MinCut cut = GlobalMinCut(n, edges);
    EXPECT_EQ(cut.value, planted);
    EXPECT_EQ(Crossing(n, edges, cut), planted);
    ASSERT_EQ(cut.side.size(), half) << "planted " << planted;
    const size_t parity = cut.side.front() % 2;
    for (size_t v : cut.side) EXPECT_EQ(v % 2, parity);
  }
}

TEST(MinCut, DisjointSpanningTreesAreEnough) {
  std::mt19937 rng(5);
  const size_t n = 400, k = 5;
  Edges edges;
  for (size_t t = 0; t < k; ++t) {
    // A random spanning tree: each vertex of a random order joins an
    // earlier one.
    std::vector<size_t> order(n);
    for (size_t v = 0; v < n; ++v) order[v] = v;
    std::shuffle(order.begin(), order.end(), rng);
    for (size_t i = 1; i < n; ++i) edges.push_back({order[i], order[rng() % i]});
  }
  // K spanning trees (parallel edges allowed) make the graph K-edge-
  // connected: the check passes without proving the exact value.
  EXPECT_GE(GlobalMinCut(n, edges, k).value, k);
  // One vertex left with a single edge: a cut of 1, found exactly.
  Edges weak;
  for (const auto& [a, b] : edges) {
    if (a != 0 && b != 0) weak.push_back({a, b});
  }
  weak.push_back({0, 1});
  const MinCut cut = GlobalMinCut(n, weak, k);
  EXPECT_EQ(cut.value, 1u);
  EXPECT_EQ(Crossing(n, weak, cut), 1u);
}

}  // namespace
}  // namespace hisfm
