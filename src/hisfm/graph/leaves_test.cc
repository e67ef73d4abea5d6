#include "hisfm/graph/leaves.h"

#include <gtest/gtest.h>

#include <set>
#include <vector>

#include "hisfm/util/error.h"

namespace hisfm {
namespace {

// Community 0 = {1, ..., 6} with skeletal images 1 and 2; community 1 =
// {7}. Leaf 3 has two skeletal neighbours and three leaf neighbours, leaf 4
// one skeletal neighbour, leaves 5 and 6 none; (6, 7) crosses communities.
struct Scene {
  ViewGraph graph;
  Communities communities;
  Skeleton skeleton;
};

Scene MakeScene() {
  Scene s;
  s.graph = ViewGraph::FromEdges(
      {1, 2, 3, 4, 5, 6, 7},
      {{ImagePair(1, 2), 200}, {ImagePair(1, 3), 100}, {ImagePair(2, 3), 90},
       {ImagePair(3, 4), 80},  {ImagePair(3, 5), 70},  {ImagePair(3, 6), 60},
       {ImagePair(1, 4), 50},  {ImagePair(4, 5), 40},  {ImagePair(4, 6), 30},
       {ImagePair(5, 6), 20},  {ImagePair(6, 7), 500}});
  s.communities.members = {{1, 2, 3, 4, 5, 6}, {7}};
  for (ImageId id = 1; id <= 6; ++id) s.communities.community_of[id] = 0;
  s.communities.community_of[7] = 1;
  s.communities.top_k_edges = {{ImagePair(1, 2), 200},
                               {ImagePair(5, 6), 20}};
  s.skeleton.images = {1, 2};
  return s;
}

std::set<ImagePair> Pairs(const std::vector<ViewGraphEdge>& edges) {
  std::set<ImagePair> out;
  for (const ViewGraphEdge& e : edges) out.insert(e.pair);
  return out;
}

TEST(AttachLeaves, SkeletalNeighboursFirstThenLeaves) {
  const Scene s = MakeScene();
  LeafOptions options;
  options.leaf_edges = 2;
  options.leaf_leaf_edges = 1;
  options.keep_top_k_edges = false;
  const std::vector<ViewGraphEdge> edges =
      AttachLeaves(s.graph, s.communities, s.skeleton, options);
  // Leaf 3: (1,3), (2,3) + (3,4). Leaf 4: (1,4) + two leaf edges, (3,4) and
  // (4,5), since it has one skeletal neighbour short. Leaves 5 and 6: three
  // leaf edges each. Never the skeleton's (1,2) nor the crossing (6,7).
  EXPECT_EQ(Pairs(edges),
            (std::set<ImagePair>{{1, 3}, {2, 3}, {3, 4}, {1, 4}, {4, 5},
                                 {3, 5}, {5, 6}, {3, 6}, {4, 6}}));
  EXPECT_EQ(edges.size(), 9u);  // unique
  for (size_t i = 1; i < edges.size(); ++i) {
    EXPECT_LT(edges[i - 1].pair, edges[i].pair);
  }
  for (const ViewGraphEdge& e : edges) {
    EXPECT_EQ(e.weight, s.graph.Weight(e.pair.image_id1, e.pair.image_id2));
  }
}

TEST(AttachLeaves, EdgeCountsFollowTheOptions) {
  const Scene s = MakeScene();
  LeafOptions options;
  options.leaf_edges = 1;
  options.leaf_leaf_edges = 0;
  options.keep_top_k_edges = false;
  // One edge per leaf: the strongest skeletal one, else the strongest leaf.
  EXPECT_EQ(Pairs(AttachLeaves(s.graph, s.communities, s.skeleton, options)),
            (std::set<ImagePair>{{1, 3}, {1, 4}, {3, 5}, {3, 6}}));
  // Two leaf-leaf edges more per leaf.
  options.leaf_leaf_edges = 2;
  EXPECT_EQ(Pairs(AttachLeaves(s.graph, s.communities, s.skeleton, options)),
            (std::set<ImagePair>{{1, 3}, {3, 4}, {3, 5}, {1, 4}, {4, 5},
                                 {5, 6}, {3, 6}, {4, 6}}));
  options.leaf_edges = 0;
  EXPECT_THROW(AttachLeaves(s.graph, s.communities, s.skeleton, options),
               Error);
  options.leaf_edges = 1;
  options.leaf_leaf_edges = -1;
  EXPECT_THROW(AttachLeaves(s.graph, s.communities, s.skeleton, options),
               Error);
}

TEST(AttachLeaves, KeepTopKEdgesAddsTheLeavesCommunityEdges) {
  const Scene s = MakeScene();
  LeafOptions options;
  options.leaf_edges = 1;
  options.leaf_leaf_edges = 0;
  options.keep_top_k_edges = true;
  // (5,6) is a top-k edge with a leaf end: kept although no leaf picks it;
  // (1,2) joins two skeletal images: not a leaf edge.
  EXPECT_EQ(Pairs(AttachLeaves(s.graph, s.communities, s.skeleton, options)),
            (std::set<ImagePair>{{1, 3}, {1, 4}, {3, 5}, {3, 6}, {5, 6}}));
}

}  // namespace
}  // namespace hisfm
