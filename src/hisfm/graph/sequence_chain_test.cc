#include "hisfm/graph/sequence_chain.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <random>
#include <set>

#include "hisfm/util/error.h"

namespace hisfm {
namespace {

// A walk of n photos: each pair matches with inliers falling with the
// distance along the walk (pairs up to 3 apart), plus doppelganger pairs a
// period of 4 apart as strong as the true neighbours, as on a repeated
// street. Image ids are 1..n in capture order.
ViewGraph WalkGraph(int n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_int_distribution<uint32_t> jitter(0, 40);
  std::vector<ImageId> images;
  std::vector<ViewGraphEdge> edges;
  for (int i = 1; i <= n; ++i) images.push_back(i);
  for (int i = 1; i <= n; ++i) {
    for (int d = 1; d <= 3 && i + d <= n; ++d) {
      edges.push_back({ImagePair(i, i + d), 400u / d + jitter(rng)});
    }
    for (int j = i + 4; j <= n; j += 4) {
      edges.push_back({ImagePair(i, j), 380u + jitter(rng)});
    }
  }
  return ViewGraph::FromEdges(images, edges);
}

// Names "000000.jpg" ... in the order given by `order` (names[order[k]] is
// the k-th name).
std::unordered_map<ImageId, std::string> NamesInOrder(
    const std::vector<ImageId>& order) {
  std::unordered_map<ImageId, std::string> names;
  for (size_t k = 0; k < order.size(); ++k) {
    char buf[32];
    std::snprintf(buf, sizeof(buf), "%06zu.jpg", k);
    names[order[k]] = buf;
  }
  return names;
}

TEST(SequenceChain, NamesInCaptureOrderGiveTheChain) {
  const ViewGraph graph = WalkGraph(60, 1);
  std::vector<ImageId> order = graph.Images();
  // Named backwards: the chain runs the other way, with the same links.
  std::reverse(order.begin(), order.end());
  const SequenceChain chain =
      FindSequenceChain(graph, NamesInOrder(order), SequenceOptions());
  EXPECT_TRUE(chain.applies);
  EXPECT_GT(chain.z_score, 5.0);
  EXPECT_DOUBLE_EQ(chain.consecutive_share, 1.0);
  EXPECT_EQ(chain.num_breaks, 0u);
  ASSERT_EQ(chain.links.size(), 59u);
  for (size_t k = 0; k < chain.links.size(); ++k) {
    EXPECT_EQ(chain.links[k], ImagePair(k + 1, k + 2));
  }
  EXPECT_EQ(chain.order.front(), 60u);
}

TEST(SequenceChain, ShuffledNamesAreNotASequence) {
  const ViewGraph graph = WalkGraph(60, 2);
  std::vector<ImageId> order = graph.Images();
  std::mt19937 rng(7);
  std::shuffle(order.begin(), order.end(), rng);
  const SequenceChain chain =
      FindSequenceChain(graph, NamesInOrder(order), SequenceOptions());
  EXPECT_FALSE(chain.applies);
  EXPECT_LT(chain.z_score, 3.0);
  EXPECT_LT(chain.consecutive_share, 0.9);

  SequenceOptions on;
  on.mode = "on";
  EXPECT_TRUE(FindSequenceChain(graph, NamesInOrder(order), on).applies);
}

TEST(SequenceChain, OffNeverApplies) {
  const ViewGraph graph = WalkGraph(30, 3);
  SequenceOptions off;
  off.mode = "off";
  const SequenceChain chain =
      FindSequenceChain(graph, NamesInOrder(graph.Images()), off);
  EXPECT_FALSE(chain.applies);
  EXPECT_GT(chain.z_score, 5.0);
}

// Where the capture jumps (from one street to the next), the consecutive
// pair is weak against its neighbours, or missing: the chain breaks there.
TEST(SequenceChain, AJumpBreaksTheChain) {
  const ViewGraph walk = WalkGraph(40, 4);
  std::vector<ViewGraphEdge> edges;
  for (ViewGraphEdge e : walk.Edges()) {
    if (e.pair == ImagePair(20, 21)) e.weight = 60;  // weak jump
    if (e.pair == ImagePair(30, 31)) continue;       // no pair at all
    edges.push_back(e);
  }
  const ViewGraph graph = ViewGraph::FromEdges(walk.Images(), edges);
  const SequenceChain chain = FindSequenceChain(
      graph, NamesInOrder(graph.Images()), SequenceOptions());
  EXPECT_TRUE(chain.applies);
  EXPECT_EQ(chain.num_breaks, 2u);
  EXPECT_EQ(chain.links.size(), 37u);
  EXPECT_FALSE(std::binary_search(chain.links.begin(), chain.links.end(),
                                  ImagePair(20, 21)));
  EXPECT_TRUE(std::binary_search(chain.links.begin(), chain.links.end(),
                                 ImagePair(19, 20)));

  SequenceOptions keep_weak;
  keep_weak.break_ratio = 0.0;
  EXPECT_EQ(FindSequenceChain(graph, NamesInOrder(graph.Images()), keep_weak)
                .links.size(),
            38u);
}

TEST(SequenceChain, NearPairsStayInsideAnUnbrokenStretch) {
  const ViewGraph walk = WalkGraph(40, 5);
  std::vector<ViewGraphEdge> edges;
  for (ViewGraphEdge e : walk.Edges()) {
    if (e.pair == ImagePair(20, 21)) continue;  // the capture jumps here
    edges.push_back(e);
  }
  const ViewGraph graph = ViewGraph::FromEdges(walk.Images(), edges);
  const SequenceChain chain = FindSequenceChain(
      graph, NamesInOrder(graph.Images()), SequenceOptions());
  ASSERT_EQ(chain.num_breaks, 1u);
  const std::vector<ImagePair> pairs = {
      ImagePair(5, 6),    // a link
      ImagePair(5, 8),    // 3 apart, links between
      ImagePair(5, 9),    // a doppelganger 4 apart: too far for window 3
      ImagePair(19, 21),  // 2 apart, across the jump
      ImagePair(21, 23),  // after the jump
      ImagePair(3, 99)};  // an image outside the order
  EXPECT_EQ(NearChainPairs(chain, pairs, 3),
            (std::vector<ImagePair>{ImagePair(5, 6), ImagePair(5, 8),
                                    ImagePair(21, 23)}));
  EXPECT_EQ(NearChainPairs(chain, pairs, 4).size(), 4u);
  EXPECT_EQ(NearChainPairs(chain, pairs, 1),
            (std::vector<ImagePair>{ImagePair(5, 6)}));
  EXPECT_TRUE(NearChainPairs(chain, pairs, 0).empty());
}

// The images of a segment's links.
std::set<ImageId> SegmentImages(const std::vector<ImagePair>& links) {
  std::set<ImageId> images;
  for (const ImagePair& p : links) images.insert({p.image_id1, p.image_id2});
  return images;
}

TEST(SequenceChain, SegmentsOverlapAndCoverEveryLink) {
  const ViewGraph graph = WalkGraph(100, 5);
  const SequenceChain chain =
      FindSequenceChain(graph, NamesInOrder(graph.Images()), SequenceOptions());
  ASSERT_EQ(chain.links.size(), 99u);
  const auto segments = ChainSegments(chain, 30, 5);
  // The fewest segments of at most 30 images that overlap by 5: 4.
  ASSERT_EQ(segments.size(), 4u);
  std::set<ImagePair> covered;
  for (size_t j = 0; j < segments.size(); ++j) {
    const std::set<ImageId> images = SegmentImages(segments[j]);
    EXPECT_LE(images.size(), 30u);
    EXPECT_TRUE(std::is_sorted(segments[j].begin(), segments[j].end()));
    covered.insert(segments[j].begin(), segments[j].end());
    if (j == 0) continue;
    const std::set<ImageId> before = SegmentImages(segments[j - 1]);
    std::vector<ImageId> shared;
    std::set_intersection(before.begin(), before.end(), images.begin(),
                          images.end(), std::back_inserter(shared));
    EXPECT_GE(shared.size(), 5u) << "segments " << j - 1 << " and " << j;
  }
  EXPECT_EQ(covered,
            std::set<ImagePair>(chain.links.begin(), chain.links.end()));
  EXPECT_EQ(*SegmentImages(segments.front()).begin(), chain.order.front());
  EXPECT_EQ(*SegmentImages(segments.back()).rbegin(), chain.order.back());
}

TEST(SequenceChain, ShortChainsAreOneSegment) {
  const ViewGraph graph = WalkGraph(20, 5);
  const SequenceChain chain =
      FindSequenceChain(graph, NamesInOrder(graph.Images()), SequenceOptions());
  EXPECT_EQ(ChainSegments(chain, 20, 5),
            std::vector<std::vector<ImagePair>>{chain.links});
  EXPECT_EQ(ChainSegments(chain, 0, 0),
            std::vector<std::vector<ImagePair>>{chain.links});
  EXPECT_EQ(ChainSegments(chain, 10, 3).size(), 3u);
  EXPECT_THROW(ChainSegments(chain, 10, 0), Error);
  EXPECT_THROW(ChainSegments(chain, 10, 10), Error);
}

TEST(SequenceChain, OptionsAreChecked) {
  SequenceOptions bad;
  bad.mode = "sometimes";
  EXPECT_THROW(bad.Check(), Error);
  bad = SequenceOptions();
  bad.break_ratio = 1.5;
  EXPECT_THROW(bad.Check(), Error);
  bad = SequenceOptions();
  bad.num_permutations = 1;
  EXPECT_THROW(bad.Check(), Error);
  const ViewGraph graph = WalkGraph(5, 5);
  std::unordered_map<ImageId, std::string> names = NamesInOrder(graph.Images());
  names.erase(3);
  EXPECT_THROW(FindSequenceChain(graph, names, SequenceOptions()), Error);
}

}  // namespace
}  // namespace hisfm
