// Global minimum cut of an undirected multigraph, used to check and restore
// the K-edge-connectivity of the skeleton's community graph.
//
// Stoer and Wagner, "A simple min-cut algorithm", J. ACM 44(4), 1997: each
// phase orders the vertices by maximum adjacency and yields the cut around
// the last one. Nagamochi and Ibaraki, "Computing edge-connectivity in
// multigraphs and capacitated graphs", SIAM J. Discrete Math. 5(1), 1992:
// the same ordering certifies that every edge whose end's adjacency reached
// a value q joins two vertices at least q-edge-connected, so each phase
// contracts every such edge at or above the best cut found so far, not only
// the last two vertices. Phases drop from n - 1 to a handful on the graphs
// the skeleton builds.
#pragma once

#include <cstddef>
#include <limits>
#include <utility>
#include <vector>

namespace hisfm {

/// A cut: its number of crossing edges and one of its two sides.
struct MinCut {
  size_t value = 0;
  std::vector<size_t> side;
};

/// Global minimum cut over vertices 0..n-1 (n >= 2); parallel edges count
/// separately. A disconnected graph has value 0. With `enough` set, the
/// search stops proving minimality at that value: a cut below `enough` is
/// still a minimum one, but when every cut has at least `enough` edges the
/// result is some cut of at least `enough` edges (checking K-edge-
/// connectivity needs no more).
MinCut GlobalMinCut(size_t n, const std::vector<std::pair<size_t, size_t>>& edges,
                    size_t enough = std::numeric_limits<size_t>::max());

}  // namespace hisfm
