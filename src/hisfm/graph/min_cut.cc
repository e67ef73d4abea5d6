#include "hisfm/graph/min_cut.h"

#include <limits>
#include <queue>
#include <unordered_map>

namespace hisfm {

MinCut GlobalMinCut(size_t n,
                    const std::vector<std::pair<size_t, size_t>>& edges) {
  std::vector<std::unordered_map<size_t, size_t>> adj(n);
  for (const auto& [a, b] : edges) {
    if (a == b) continue;
    ++adj[a][b];
    ++adj[b][a];
  }
  // members[v]: original vertices merged into v.
  std::vector<std::vector<size_t>> members(n);
  for (size_t v = 0; v < n; ++v) members[v] = {v};
  std::vector<bool> alive(n, true);
  MinCut best;
  best.value = std::numeric_limits<size_t>::max();
  for (size_t phase = 1; phase < n; ++phase) {
    // Maximum adjacency ordering from any live vertex.
    std::vector<size_t> key(n, 0);
    std::vector<bool> added(n, false);
    std::priority_queue<std::pair<size_t, size_t>> heap;
    for (size_t v = 0; v < n; ++v)
      if (alive[v]) heap.push({0, v});
    size_t prev = n, last = n;
    while (!heap.empty()) {
      const auto [k, v] = heap.top();
      heap.pop();
      if (added[v] || k != key[v]) continue;
      added[v] = true;
      prev = last;
      last = v;
      for (const auto& [u, w] : adj[v]) {
        if (!added[u]) {
          key[u] += w;
          heap.push({key[u], u});
        }
      }
    }
    if (key[last] < best.value) {
      best.value = key[last];
      best.side = members[last];
    }
    // Merge `last` into `prev`.
    for (const auto& [u, w] : adj[last]) {
      if (u == prev) continue;
      adj[prev][u] += w;
      adj[u][prev] += w;
      adj[u].erase(last);
    }
    adj[prev].erase(last);
    adj[last].clear();
    alive[last] = false;
    members[prev].insert(members[prev].end(), members[last].begin(),
                         members[last].end());
  }
  if (n < 2) best.value = 0;
  return best;
}

}  // namespace hisfm
