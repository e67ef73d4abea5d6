#include "hisfm/verify/keypoint_multisets.h"

#include <algorithm>

namespace hisfm {

size_t KeypointMultisets::Add(size_t num_keypoints, FeatureMatchSpan inliers) {
  Entry e;
  e.index_offset = indices_.size();
  const size_t num_words = (num_keypoints + 63) / 64;
  // A bitmap costs 8 bytes a word, the list 4 bytes an index.
  if (num_words > 0 && 2 * num_words <= inliers.size()) {
    e.word_offset = words_.size();
    e.num_words = static_cast<uint32_t>(num_words);
    words_.resize(words_.size() + num_words, 0);
    uint64_t* bits = words_.data() + e.word_offset;
    // The word being filled stays in a register until the index moves to
    // another word (inliers mostly come in keypoint order).
    size_t word = 0;
    uint64_t current = bits[0];
    for (const FeatureMatch& m : inliers) {
      if (m.idx1 >= num_keypoints) continue;
      if (m.idx1 / 64 != word) {
        bits[word] = current;
        word = m.idx1 / 64;
        current = bits[word];
      }
      const uint64_t bit = uint64_t{1} << (m.idx1 % 64);
      if (current & bit) {
        indices_.push_back(m.idx1);  // A repeat.
      } else {
        current |= bit;
      }
    }
    bits[word] = current;
  } else {
    for (const FeatureMatch& m : inliers) {
      if (m.idx1 < num_keypoints) indices_.push_back(m.idx1);
    }
  }
  e.num_indices = static_cast<uint32_t>(indices_.size() - e.index_offset);
  entries_.push_back(e);
  return entries_.size() - 1;
}

namespace {

// Capacity of `v` once `more` elements are appended (vectors double).
template <typename T>
size_t CapacityAfter(const std::vector<T>& v, size_t more) {
  const size_t need = v.size() + more;
  return need <= v.capacity() ? v.capacity()
                              : std::max(need, 2 * v.capacity());
}

}  // namespace

size_t KeypointMultisets::BytesAfterAdding(size_t num_keypoints,
                                           size_t num_inliers) const {
  // At most a bitmap and every index (repeats), or the list.
  const size_t num_words = (num_keypoints + 63) / 64;
  return CapacityAfter(entries_, 1) * sizeof(Entry) +
         CapacityAfter(words_, num_words) * sizeof(uint64_t) +
         CapacityAfter(indices_, num_inliers) * sizeof(uint32_t);
}

size_t KeypointMultisets::Bytes() const {
  return entries_.capacity() * sizeof(Entry) +
         words_.capacity() * sizeof(uint64_t) +
         indices_.capacity() * sizeof(uint32_t);
}

size_t KeypointMultisets::CountIn(size_t k, const uint64_t* bits,
                                  size_t num_words) const {
  const Entry& e = entries_.at(k);
  size_t count = 0;
  const uint64_t* words = words_.data() + e.word_offset;
  const size_t common = std::min<size_t>(e.num_words, num_words);
  for (size_t w = 0; w < common; ++w) {
    count += __builtin_popcountll(words[w] & bits[w]);
  }
  for (uint32_t i = 0; i < e.num_indices; ++i) {
    const uint32_t idx = indices_[e.index_offset + i];
    if (idx / 64 < num_words) count += (bits[idx / 64] >> (idx % 64)) & 1;
  }
  return count;
}

}  // namespace hisfm
