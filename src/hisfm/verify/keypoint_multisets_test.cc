#include "hisfm/verify/keypoint_multisets.h"

#include <gtest/gtest.h>

#include <random>

namespace hisfm {
namespace {

// Counts the way KeypointMultisets::CountIn is defined: every in-range idx1,
// with multiplicity, whose bit is set among the first num_words words.
size_t CountSlowly(size_t num_keypoints, const std::vector<FeatureMatch>& m,
                   const std::vector<uint64_t>& bits, size_t num_words) {
  size_t count = 0;
  for (const FeatureMatch& f : m) {
    if (f.idx1 >= num_keypoints || f.idx1 / 64 >= num_words) continue;
    count += (bits[f.idx1 / 64] >> (f.idx1 % 64)) & 1;
  }
  return count;
}

TEST(KeypointMultisets, CountsLikeTheInliersThemselves) {
  std::mt19937 rng(17);
  KeypointMultisets sets;
  struct Case {
    size_t num_keypoints;
    std::vector<FeatureMatch> matches;
  };
  std::vector<Case> cases;
  size_t num_bitmaps = 0, num_lists = 0, num_repeats = 0;
  for (int trial = 0; trial < 400; ++trial) {
    Case c;
    c.num_keypoints = 1 + rng() % 700;
    // From a few inliers (the list form) to many (the bitmap form), some
    // indices repeated and some beyond the image's keypoints.
    const size_t n = rng() % (trial % 2 ? 8 : 120);
    for (size_t i = 0; i < n; ++i) {
      const Point2DIdx idx1 =
          static_cast<Point2DIdx>(rng() % (c.num_keypoints + 5));
      c.matches.push_back({idx1, static_cast<Point2DIdx>(rng() % 50)});
    }
    std::vector<char> seen(c.num_keypoints + 5, 0);
    for (const FeatureMatch& m : c.matches) num_repeats += seen[m.idx1]++ > 0;
    const size_t words = (c.num_keypoints + 63) / 64;
    (2 * words <= n ? num_bitmaps : num_lists) += 1;
    EXPECT_EQ(sets.Add(c.num_keypoints, c.matches), cases.size());
    cases.push_back(std::move(c));
  }
  ASSERT_EQ(sets.Size(), cases.size());
  EXPECT_GT(num_bitmaps, 50u);
  EXPECT_GT(num_lists, 50u);
  EXPECT_GT(num_repeats, 50u);
  EXPECT_GT(sets.Bytes(), 0u);
  for (size_t k = 0; k < cases.size(); ++k) {
    const Case& c = cases[k];
    const size_t words = (c.num_keypoints + 63) / 64;
    std::vector<uint64_t> bits(words);
    for (uint64_t& w : bits) w = (uint64_t{rng()} << 32) | rng();
    // The whole image, and fewer words than it has (the rest count as
    // unset).
    for (const size_t num_words : {words, words / 2}) {
      EXPECT_EQ(sets.CountIn(k, bits.data(), num_words),
                CountSlowly(c.num_keypoints, c.matches, bits, num_words))
          << "multiset " << k << ", " << num_words << " words";
    }
    std::vector<uint64_t> all(words, ~uint64_t{0});
    size_t in_range = 0;
    for (const FeatureMatch& m : c.matches) in_range += m.idx1 < c.num_keypoints;
    EXPECT_EQ(sets.CountIn(k, all.data(), words), in_range);
  }
}

// An image without keypoints (no keypoints row): every index is out of
// range, nothing is kept, and counting reads no word.
TEST(KeypointMultisets, ImageWithoutKeypoints) {
  KeypointMultisets sets;
  const std::vector<FeatureMatch> matches = {{0, 1}, {3, 2}, {3, 4}, {9, 9}};
  const size_t before = sets.BytesAfterAdding(0, matches.size());
  const size_t k = sets.Add(0, matches);
  EXPECT_LE(sets.Bytes(), before);
  EXPECT_EQ(sets.CountIn(k, nullptr, 0), 0u);
  const uint64_t all = ~uint64_t{0};
  EXPECT_EQ(sets.CountIn(k, &all, 1), 0u);
  // Growth is counted before it happens.
  for (int i = 0; i < 100; ++i) {
    const size_t bound = sets.BytesAfterAdding(700, matches.size());
    sets.Add(700, matches);
    EXPECT_LE(sets.Bytes(), bound) << i;
  }
}

}  // namespace
}  // namespace hisfm
