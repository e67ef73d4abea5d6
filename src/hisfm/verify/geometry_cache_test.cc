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
  auto expect_same = [](const PairGeometry& a, const PairGeometry& b) {
    EXPECT_EQ(a.from, b.from);
    EXPECT_EQ(a.matches.size(), b.matches.size());
    EXPECT_EQ(a.from_to, b.from_to);
    ASSERT_EQ(a.hypotheses.size(), b.hypotheses.size());
    for (size_t h = 0; h < a.hypotheses.size(); ++h) {
      const Rigid3d& x = a.hypotheses[h].cam2_from_cam1;
      const Rigid3d& y = b.hypotheses[h].cam2_from_cam1;
      EXPECT_EQ(a.hypotheses[h].num_support, b.hypotheses[h].num_support);
      EXPECT_TRUE(x.translation.isApprox(y.translation, 1e-12));
      EXPECT_TRUE(x.rotation.coeffs().isApprox(y.rotation.coeffs(), 1e-12));
    }
  };
  size_t with_pose = 0;
  for (size_t k = 0; k < got.size(); ++k) {
    const ImagePair& p = pairs[k % pairs.size()];
    EXPECT_EQ(got[k], got[k % pairs.size()]) << k;
    expect_same(*got[k], *serial.Pair(p.image_id1, p.image_id2));
    with_pose += !got[k]->hypotheses.empty();
  }
  for (const ImagePair& p : pairs) {
    // The reversed orientations made concurrently are stored once too.
    const auto reversed = shared.Pair(p.image_id2, p.image_id1);
    EXPECT_EQ(reversed, shared.Pair(p.image_id2, p.image_id1));
    expect_same(*reversed, *serial.Pair(p.image_id2, p.image_id1));
  }
  EXPECT_GT(with_pose, got.size() / 2);
}

}  // namespace
}  // namespace hisfm
