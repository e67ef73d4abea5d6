#include "hisfm/graph/graph_segments.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <iterator>
#include <map>
#include <random>
#include <set>

#include "hisfm/graph/union_find.h"
#include "hisfm/util/error.h"

namespace hisfm {
namespace {

// A street of `n` images whose ids are shuffled (fixed seed): image k of
// the street overlaps images k+1 .. k+reach. Returns the ids in street order.
std::vector<ImageId> ShuffledStreet(size_t n, size_t reach,
                                    std::vector<ImagePair>* edges) {
  std::vector<ImageId> street(n);
  for (size_t k = 0; k < n; ++k) street[k] = static_cast<ImageId>(k + 1);
  std::mt19937 rng(7);
  std::shuffle(street.begin(), street.end(), rng);
  for (size_t k = 0; k < n; ++k) {
    for (size_t d = 1; d <= reach && k + d < n; ++d) {
      edges->push_back(ImagePair(street[k], street[k + d]));
    }
  }
  return street;
}

// Whether the edges inside `images` connect them.
bool Connected(const std::vector<ImageId>& images,
               const std::vector<ImagePair>& edges) {
  const std::set<ImageId> in(images.begin(), images.end());
  std::map<ImageId, size_t> index;
  for (ImageId id : images) index.emplace(id, index.size());
  UnionFind sets(images.size());
  for (const ImagePair& e : edges) {
    if (in.count(e.image_id1) && in.count(e.image_id2)) {
      sets.Union(index[e.image_id1], index[e.image_id2]);
    }
  }
  for (ImageId id : images) {
    if (sets.Find(index[id]) != sets.Find(0)) return false;
  }
  return true;
}

TEST(GraphSegments, SpansAreFewestEvenAndOverlapping) {
  EXPECT_TRUE(OverlappingSpans(0, 10, 3).empty());
  EXPECT_EQ(OverlappingSpans(10, 10, 3),
            (std::vector<std::pair<size_t, size_t>>{{0, 10}}));
  EXPECT_EQ(OverlappingSpans(50, 0, 0),
            (std::vector<std::pair<size_t, size_t>>{{0, 50}}));
  // 100 places, at most 30 each, sharing at least 5: 4 spans of 29.
  const auto spans = OverlappingSpans(100, 30, 5);
  ASSERT_EQ(spans.size(), 4u);
  EXPECT_EQ(spans.front().first, 0u);
  EXPECT_EQ(spans.back().second, 100u);
  for (size_t j = 0; j < spans.size(); ++j) {
    EXPECT_EQ(spans[j].second - spans[j].first, 29u);
    if (j > 0) EXPECT_GE(spans[j - 1].second - spans[j].first, 5u);
  }
  EXPECT_THROW(OverlappingSpans(100, 30, 0), Error);
  EXPECT_THROW(OverlappingSpans(100, 30, 30), Error);
}

TEST(GraphSegments, BandedOrderRecoversAShuffledStreet) {
  std::vector<ImagePair> edges;
  const std::vector<ImageId> street = ShuffledStreet(200, 3, &edges);
  std::vector<ImageId> images = street;
  std::sort(images.begin(), images.end());
  images.push_back(1000);  // no edge: last
  const std::vector<ImageId> order = BandedOrder(images, edges);
  ASSERT_EQ(order.size(), images.size());
  EXPECT_EQ(std::set<ImageId>(order.begin(), order.end()),
            std::set<ImageId>(images.begin(), images.end()));
  EXPECT_EQ(order.back(), 1000u);
  std::map<ImageId, size_t> place;
  for (size_t k = 0; k < order.size(); ++k) place[order[k]] = k;
  // Every edge joins images near each other in the order (the street's
  // own order has bandwidth 3; the shuffled ids are up to 199 apart).
  size_t bandwidth = 0;
  for (const ImagePair& e : edges) {
    const size_t a = place[e.image_id1];
    const size_t b = place[e.image_id2];
    bandwidth = std::max(bandwidth, a > b ? a - b : b - a);
  }
  EXPECT_LE(bandwidth, 6u);
  // It starts at an end of the street.
  EXPECT_TRUE(order.front() == street.front() ||
              order.front() == street.back());
}

TEST(GraphSegments, BandedOrderKeepsComponentsApart) {
  // Two streets without an edge between them, ids interleaved, and an edge
  // to an image that is not in the list.
  std::vector<ImagePair> edges;
  std::vector<ImageId> images;
  for (ImageId k = 1; k <= 40; ++k) images.push_back(k);
  for (ImageId k = 1; k + 2 <= 40; ++k) edges.push_back(ImagePair(k, k + 2));
  edges.push_back(ImagePair(1, 99));
  const std::vector<ImageId> order = BandedOrder(images, edges);
  ASSERT_EQ(order.size(), 40u);
  // One street (odd or even ids) after the other, each from an end.
  for (size_t k = 0; k < 20; ++k) {
    EXPECT_EQ(order[k] % 2, order[0] % 2) << k;
    EXPECT_NE(order[k + 20] % 2, order[0] % 2) << k;
  }
  EXPECT_TRUE(order[0] <= 2 || order[0] >= 39) << order[0];
  EXPECT_TRUE(order[20] <= 2 || order[20] >= 39) << order[20];
}

TEST(GraphSegments, SegmentsAreConnectedOverlapAndCoverTheGraph) {
  std::vector<ImagePair> edges;
  const std::vector<ImageId> street = ShuffledStreet(1000, 3, &edges);
  const auto segments = GraphSegments(street, edges, 300, 30);
  ASSERT_EQ(segments.size(), 4u);
  std::set<ImageId> covered;
  for (size_t j = 0; j < segments.size(); ++j) {
    EXPECT_LE(segments[j].size(), 300u);
    EXPECT_TRUE(Connected(segments[j], edges)) << "segment " << j;
    covered.insert(segments[j].begin(), segments[j].end());
    if (j == 0) continue;
    std::set<ImageId> before(segments[j - 1].begin(), segments[j - 1].end());
    std::set<ImageId> now(segments[j].begin(), segments[j].end());
    std::vector<ImageId> shared;
    std::set_intersection(before.begin(), before.end(), now.begin(), now.end(),
                          std::back_inserter(shared));
    EXPECT_GE(shared.size(), 30u) << "segments " << j - 1 << " and " << j;
    // The shared images are connected in both segments.
    EXPECT_TRUE(Connected(shared, edges)) << "segments " << j - 1 << ", " << j;
  }
  EXPECT_EQ(covered.size(), street.size());
  // Every edge lies inside a segment.
  size_t inside = 0;
  for (const ImagePair& e : edges) {
    for (const auto& s : segments) {
      if (std::count(s.begin(), s.end(), e.image_id1) &&
          std::count(s.begin(), s.end(), e.image_id2)) {
        ++inside;
        break;
      }
    }
  }
  EXPECT_EQ(inside, edges.size());
  // Small graphs are one segment, in their given order.
  const std::vector<ImageId> few(street.begin(), street.begin() + 20);
  EXPECT_EQ(GraphSegments(few, edges, 300, 30),
            std::vector<std::vector<ImageId>>{few});
  EXPECT_TRUE(GraphSegments({}, edges, 300, 30).empty());
}

}  // namespace
}  // namespace hisfm
