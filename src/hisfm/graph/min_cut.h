// Global minimum cut of an undirected multigraph (Stoer and Wagner, "A simple
// min-cut algorithm", J. ACM 44(4), 1997), used to check and restore the
// K-edge-connectivity of the skeleton's community graph.
#pragma once

#include <cstddef>
#include <utility>
#include <vector>

namespace hisfm {

/// A minimum cut: its number of crossing edges and one of its two sides.
struct MinCut {
  size_t value = 0;
  std::vector<size_t> side;
};

/// Global minimum cut over vertices 0..n-1 (n >= 2); parallel edges count
/// separately. A disconnected graph has value 0.
MinCut GlobalMinCut(size_t n, const std::vector<std::pair<size_t, size_t>>& edges);

}  // namespace hisfm
