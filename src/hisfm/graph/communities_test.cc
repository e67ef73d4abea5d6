#include "hisfm/graph/communities.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <random>
#include <map>
#include <set>

#include "hisfm/util/error.h"

namespace hisfm {
namespace {

ViewGraph RandomGraph(int num_images, double density, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  std::uniform_int_distribution<uint32_t> w(15, 500);
  std::vector<ImageId> images;
  std::vector<ViewGraphEdge> edges;
  for (int i = 1; i <= num_images; ++i) images.push_back(i);
  for (int i = 1; i <= num_images; ++i)
    for (int j = i + 1; j <= num_images; ++j)
      if (u(rng) < density) edges.push_back({ImagePair(i, j), w(rng)});
  return ViewGraph::FromEdges(images, edges);
}

// Reference: components of the graph made of each image's k strongest edges,
// by a plain flood fill.
std::set<std::set<ImageId>> ReferenceCommunities(const ViewGraph& g, int k) {
  std::map<ImageId, std::set<ImageId>> adj;
  for (ImageId id : g.Images()) {
    std::vector<std::pair<uint32_t, ImageId>> nb;
    for (size_t e : g.IncidentEdges(g.IndexOf(id))) {
      nb.push_back({g.Edges()[e].weight, g.OtherEnd(e, id)});
    }
    std::sort(nb.begin(), nb.end(), [](const auto& a, const auto& b) {
      return a.first > b.first || (a.first == b.first && a.second < b.second);
    });
    adj[id];
    for (int t = 0; t < k && t < static_cast<int>(nb.size()); ++t) {
      adj[id].insert(nb[t].second);
      adj[nb[t].second].insert(id);
    }
  }
  std::set<std::set<ImageId>> out;
  std::set<ImageId> seen;
  for (ImageId id : g.Images()) {
    if (seen.count(id)) continue;
    std::set<ImageId> comp;
    std::vector<ImageId> stack = {id};
    while (!stack.empty()) {
      ImageId x = stack.back();
      stack.pop_back();
      if (!comp.insert(x).second) continue;
      seen.insert(x);
      for (ImageId y : adj[x]) stack.push_back(y);
    }
    out.insert(comp);
  }
  return out;
}

TEST(Communities, EqualComponentsOfTopKGraph) {
  for (uint32_t seed = 0; seed < 20; ++seed) {
    for (int k : {1, 2, 3}) {
      const ViewGraph g = RandomGraph(40, 0.15, seed);
      CommunityOptions options;
      options.top_k = k;
      const Communities c = ComputeCommunities(g, options);
      std::set<std::set<ImageId>> got;
      for (const auto& m : c.members) got.insert({m.begin(), m.end()});
      EXPECT_EQ(got, ReferenceCommunities(g, k)) << "seed " << seed;
      for (const auto& [id, community] : c.community_of) {
        const auto& m = c.members[community];
        EXPECT_TRUE(std::binary_search(m.begin(), m.end(), id));
      }
    }
  }
}

TEST(Communities, TopOneKeepsStrongestNeighbour) {
  // A chain 1-2-3-4 with weights 100, 10, 100: communities {1,2} and {3,4}.
  const ViewGraph g = ViewGraph::FromEdges(
      {1, 2, 3, 4}, {{ImagePair(1, 2), 100},
                     {ImagePair(2, 3), 10},
                     {ImagePair(3, 4), 100}});
  const Communities c = ComputeCommunities(g, CommunityOptions());
  ASSERT_EQ(c.NumCommunities(), 2u);
  EXPECT_EQ(c.Of(1), c.Of(2));
  EXPECT_EQ(c.Of(3), c.Of(4));
  EXPECT_NE(c.Of(2), c.Of(3));
  EXPECT_EQ(c.top_k_edges.size(), 2u);
}

TEST(Communities, IsolatedImageIsItsOwnCommunity) {
  const ViewGraph g =
      ViewGraph::FromEdges({1, 2, 3}, {{ImagePair(1, 2), 50}});
  const Communities c = ComputeCommunities(g, CommunityOptions());
  EXPECT_EQ(c.NumCommunities(), 2u);
  EXPECT_NE(c.Of(3), c.Of(1));
}

TEST(Communities, RejectsBadOptions) {
  CommunityOptions options;
  options.top_k = 0;
  EXPECT_THROW(options.Check(), Error);
}

}  // namespace
}  // namespace hisfm
