// Compact record of which keypoints of one image many pairs' inliers use.
//
// The builtin verifier needs, for every bridge, how many of its inliers sit
// on distinctive keypoints (track_consistency.h); which keypoints are
// distinctive is known only once the tracks of all pairs are joined, one
// full read of the inliers later. Keeping each bridge's inliers for that
// count would hold the whole match table in memory (2.8 GB on the
// benchmark's 5,000-image street); re-reading them costs a second scan of
// the table. A pair's inliers use each keypoint of its first image at most
// a few times, so a bitmap over that image's keypoints (80 bytes for 640
// keypoints, against 2.8 kB for its 350 inlier pairs) plus the rare
// repeated indices holds the same count; when the image has many more
// keypoints than the pair has inliers, the list of indices is smaller and
// kept instead.
#pragma once

#include <cstddef>
#include <cstdint>
#include <vector>

#include "hisfm/io/database.h"

namespace hisfm {

/// Multisets of keypoint indices of one image each, stored compactly.
class KeypointMultisets {
 public:
  /// Records the first-image keypoints (idx1) of `inliers`, the image
  /// having `num_keypoints` keypoints; indices at or beyond it are left
  /// out. Returns the multiset's index (0, 1, 2, ... in call order).
  size_t Add(size_t num_keypoints, FeatureMatchSpan inliers);

  /// Number of multisets.
  size_t Size() const { return entries_.size(); }
  /// Bytes held (capacity).
  size_t Bytes() const;
  /// Bytes held at most after an Add of that many keypoints and inliers,
  /// counting the growth of the buffers.
  size_t BytesAfterAdding(size_t num_keypoints, size_t num_inliers) const;

  /// Number of members of multiset `k`, with multiplicity, that are set in
  /// `bits`: bit i of bits[i / 64] for keypoint i, over `num_words` words
  /// (members beyond them count as unset).
  size_t CountIn(size_t k, const uint64_t* bits, size_t num_words) const;

 private:
  struct Entry {
    // Bitmap words in words_ (0 for the list form).
    size_t word_offset = 0;
    uint32_t num_words = 0;
    // Indices in indices_: repeats of the bitmap form, or all members of
    // the list form.
    size_t index_offset = 0;
    uint32_t num_indices = 0;
  };
  std::vector<Entry> entries_;
  std::vector<uint64_t> words_;
  std::vector<uint32_t> indices_;
};

}  // namespace hisfm
