#include "hisfm/verify/geometry_cache.h"

#include <gtest/gtest.h>

#include <memory>
#include <vector>

#include "hisfm/util/error.h"
#include "hisfm/util/parallel.h"
#include "hisfm/verify/street_test_scene.h"

namespace hisfm {
namespace {

TEST(GeometryCache, PairsAreOrientedAsAskedAndStoredOnce) {
  street_test::Opened street(1, 8);
  GeometryCache cache(street.db, street.graph);
  const ImagePair pair = street.graph.Pairs().front();
  const auto forward = cache.Pair(pair.image_id1, pair.image_id2);
  const auto backward = cache.Pair(pair.image_id2, pair.image_id1);
  EXPECT_EQ(forward, cache.Pair(pair.image_id1, pair.image_id2));
  EXPECT_EQ(backward, cache.Pair(pair.image_id2, pair.image_id1));
  EXPECT_EQ(forward->from, pair.image_id1);
  EXPECT_EQ(backward->from, pair.image_id2);
  ASSERT_EQ(forward->matches.size(), backward->matches.size());
  ASSERT_FALSE(forward->matches.empty());
  EXPECT_EQ(forward->matches[0].idx1, backward->matches[0].idx2);
  EXPECT_EQ(&cache.Image(pair.image_id1), &cache.Image(pair.image_id1));
  EXPECT_THROW(cache.Image(9999), Error);
}

// Many threads asking for the same pairs at once get one stored geometry
// per pair, equal to what a cache used from one thread computes.
TEST(GeometryCache, ConcurrentCallersShareOneGeometryPerPair) {
  street_test::Opened street(1, 8);
  const std::vector<ImagePair> pairs = street.graph.Pairs();
  GeometryCache serial(street.db, street.graph);
  GeometryCache shared(street.db, street.graph);
  const size_t rounds = 4;
  std::vector<std::shared_ptr<const PairGeometry>> got(rounds * pairs.size());
  ParallelFor(got.size(), 4, [&](size_t k) {
    const ImagePair& p = pairs[k % pairs.size()];
    // Half the callers ask in the reversed orientation first.
    if ((k / pairs.size()) % 2) shared.Pair(p.image_id2, p.image_id1);
    got[k] = shared.Pair(p.image_id1, p.image_id2);
  });
  for (size_t k = 0; k < got.size(); ++k) {
    const ImagePair& p = pairs[k % pairs.size()];
    EXPECT_EQ(got[k], got[k % pairs.size()]) << k;
    const auto expected = serial.Pair(p.image_id1, p.image_id2);
    ASSERT_EQ(got[k]->hypotheses.size(), expected->hypotheses.size());
    for (size_t h = 0; h < expected->hypotheses.size(); ++h) {
      EXPECT_EQ(got[k]->hypotheses[h].num_support,
                expected->hypotheses[h].num_support);
      EXPECT_TRUE(got[k]->hypotheses[h].cam2_from_cam1.translation.isApprox(
          expected->hypotheses[h].cam2_from_cam1.translation, 1e-12));
    }
    EXPECT_EQ(got[k]->matches.size(), expected->matches.size());
  }
}

}  // namespace
}  // namespace hisfm
