// Disjoint-set union with path halving and union by size, on 32-bit indices
// (half the memory of size_t: the track builder keeps millions of keypoints
// in one).
#pragma once

#include <cstdint>
#include <limits>
#include <numeric>
#include <vector>

#include "hisfm/util/error.h"

namespace hisfm {

/// Disjoint sets over 0..n-1 (n < 2^32).
class UnionFind {
 public:
  explicit UnionFind(size_t n) : parent_(n), size_(n, 1) {
    ThrowUnless(n <= std::numeric_limits<uint32_t>::max(),
                "union-find: too many elements");
    std::iota(parent_.begin(), parent_.end(), uint32_t{0});
  }
  /// Representative of x's set.
  size_t Find(size_t x) {
    uint32_t y = static_cast<uint32_t>(x);
    while (parent_[y] != y) {
      parent_[y] = parent_[parent_[y]];
      y = parent_[y];
    }
    return y;
  }
  /// Merges the sets of a and b; false if they were already one set.
  bool Union(size_t a, size_t b) {
    uint32_t ra = static_cast<uint32_t>(Find(a));
    uint32_t rb = static_cast<uint32_t>(Find(b));
    if (ra == rb) return false;
    if (size_[ra] < size_[rb]) std::swap(ra, rb);
    parent_[rb] = ra;
    size_[ra] += size_[rb];
    return true;
  }
  /// Whether a and b are in one set.
  bool Connected(size_t a, size_t b) { return Find(a) == Find(b); }

 private:
  std::vector<uint32_t> parent_;
  std::vector<uint32_t> size_;
};

}  // namespace hisfm
