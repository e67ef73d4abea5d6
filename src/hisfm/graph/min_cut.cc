#include "hisfm/graph/min_cut.h"

#include <algorithm>
#include <queue>

#include "hisfm/graph/union_find.h"

namespace hisfm {
namespace {

// An edge of the contracted graph with its multiplicity.
struct WeightedEdge {
  size_t a = 0;
  size_t b = 0;
  size_t weight = 0;
};

// Sorts the edges and merges parallel ones.
void MergeParallel(std::vector<WeightedEdge>* edges) {
  std::sort(edges->begin(), edges->end(),
            [](const WeightedEdge& x, const WeightedEdge& y) {
              return x.a < y.a || (x.a == y.a && x.b < y.b);
            });
  size_t out = 0;
  for (const WeightedEdge& e : *edges) {
    if (out > 0 && (*edges)[out - 1].a == e.a && (*edges)[out - 1].b == e.b) {
      (*edges)[out - 1].weight += e.weight;
    } else {
      (*edges)[out++] = e;
    }
  }
  edges->resize(out);
}

}  // namespace

MinCut GlobalMinCut(size_t n,
                    const std::vector<std::pair<size_t, size_t>>& edges,
                    size_t enough) {
  MinCut best;
  best.value = std::numeric_limits<size_t>::max();
  if (n < 2) {
    best.value = 0;
    return best;
  }
  // The contracted graph: vertices 0..num-1, members[v] the original
  // vertices merged into v.
  size_t num = n;
  std::vector<std::vector<size_t>> members(n);
  for (size_t v = 0; v < n; ++v) members[v] = {v};
  std::vector<WeightedEdge> current;
  current.reserve(edges.size());
  for (const auto& [a, b] : edges) {
    if (a != b) current.push_back({std::min(a, b), std::max(a, b), 1});
  }
  while (num > 1) {
    MergeParallel(&current);
    std::vector<size_t> offsets(num + 1, 0);
    for (const WeightedEdge& e : current) {
      ++offsets[e.a + 1];
      ++offsets[e.b + 1];
    }
    for (size_t v = 0; v < num; ++v) offsets[v + 1] += offsets[v];
    std::vector<std::pair<size_t, size_t>> adjacent(offsets[num]);
    std::vector<size_t> degree(num, 0), fill(offsets.begin(), offsets.end() - 1);
    for (const WeightedEdge& e : current) {
      adjacent[fill[e.a]++] = {e.b, e.weight};
      adjacent[fill[e.b]++] = {e.a, e.weight};
      degree[e.a] += e.weight;
      degree[e.b] += e.weight;
    }
    // The cut around a single vertex is a candidate too: it sets the
    // contraction threshold from the first phase on.
    for (size_t v = 0; v < num; ++v) {
      if (degree[v] < best.value) {
        best.value = degree[v];
        best.side = members[v];
      }
    }
    if (best.value == 0) break;
    const size_t threshold = std::min(best.value, enough);

    // Maximum adjacency ordering; key[u]: edges from the ordered vertices.
    std::vector<size_t> key(num, 0);
    std::vector<char> ordered(num, 0);
    std::priority_queue<std::pair<size_t, size_t>> heap;
    for (size_t v = 0; v < num; ++v) heap.push({0, v});
    UnionFind contract(num);
    size_t prev = num, last = num;
    while (!heap.empty()) {
      const auto [k, v] = heap.top();
      heap.pop();
      if (ordered[v] || k != key[v]) continue;
      ordered[v] = 1;
      prev = last;
      last = v;
      for (size_t i = offsets[v]; i < offsets[v + 1]; ++i) {
        const auto [u, w] = adjacent[i];
        if (ordered[u]) continue;
        key[u] += w;
        // Nagamochi-Ibaraki: u and v are at least key[u]-edge-connected.
        if (key[u] >= threshold) contract.Union(u, v);
        heap.push({key[u], u});
      }
    }
    // The cut of the phase separates the last vertex from the rest.
    if (key[last] < best.value) {
      best.value = key[last];
      best.side = members[last];
    }
    // prev and last are key[last]-edge-connected, at least the best cut.
    contract.Union(prev, last);

    // Relabel the contracted vertices.
    std::vector<size_t> label(num, num);
    size_t next = 0;
    std::vector<std::vector<size_t>> merged;
    for (size_t v = 0; v < num; ++v) {
      const size_t root = contract.Find(v);
      if (label[root] == num) {
        label[root] = next++;
        merged.emplace_back();
      }
      std::vector<size_t>& into = merged[label[root]];
      into.insert(into.end(), members[v].begin(), members[v].end());
    }
    size_t kept = 0;
    for (const WeightedEdge& e : current) {
      const size_t a = label[contract.Find(e.a)];
      const size_t b = label[contract.Find(e.b)];
      if (a != b) current[kept++] = {std::min(a, b), std::max(a, b), e.weight};
    }
    current.resize(kept);
    members = std::move(merged);
    num = next;
  }
  return best;
}

}  // namespace hisfm
