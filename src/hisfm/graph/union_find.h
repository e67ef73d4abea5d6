// Disjoint-set union with path halving and union by size.
#pragma once

#include <numeric>
#include <vector>

namespace hisfm {

/// Disjoint sets over 0..n-1.
class UnionFind {
 public:
  explicit UnionFind(size_t n) : parent_(n), size_(n, 1) {
    std::iota(parent_.begin(), parent_.end(), size_t{0});
  }
  /// Representative of x's set.
  size_t Find(size_t x) {
    while (parent_[x] != x) {
      parent_[x] = parent_[parent_[x]];
      x = parent_[x];
    }
    return x;
  }
  /// Merges the sets of a and b; false if they were already one set.
  bool Union(size_t a, size_t b) {
    a = Find(a);
    b = Find(b);
    if (a == b) return false;
    if (size_[a] < size_[b]) std::swap(a, b);
    parent_[b] = a;
    size_[a] += size_[b];
    return true;
  }
  bool Connected(size_t a, size_t b) { return Find(a) == Find(b); }

 private:
  std::vector<size_t> parent_;
  std::vector<size_t> size_;
};

}  // namespace hisfm
