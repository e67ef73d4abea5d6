#include "hisfm/verify/three_view_consistency.h"

#include <gtest/gtest.h>

#include "hisfm/util/error.h"
#include "hisfm/util/test_util.h"
#include "hisfm/verify/street_test_scene.h"
#include "hisfm/verify/view_graph_reader.h"

namespace hisfm {
namespace {

TEST(ThreeViewOptions, CheckRejectsBadValues) {
  ThreeViewOptions o;
  EXPECT_NO_THROW(o.Check());
  o.max_error_px = 0;
  EXPECT_THROW(o.Check(), Error);
  o = ThreeViewOptions();
  o.min_triangulation_angle_deg = -1;
  EXPECT_THROW(o.Check(), Error);
  o = ThreeViewOptions();
  o.min_scale_points = 0;
  EXPECT_THROW(o.Check(), Error);
  o = ThreeViewOptions();
  o.max_shared_points = -1;
  EXPECT_THROW(o.Check(), Error);
}

// The repeated test street (16 photos, seed 5), its tracks and geometry.
struct Street : street_test::Opened {
  Street() : Opened(5) {}
  TrackConsistency tracks{db, graph};
  PairGeometryCache cache{db};

  // The third view of `pair` seen from its first image x: x's neighbour one
  // photo away, if it is not the pair's other image and (x, t) is a pair of
  // the street; 0 otherwise.
  ImageId ThirdView(const ImagePair& pair) const {
    const ImageId x = pair.image_id1;
    const ImageId t = x > 1 ? x - 1 : x + 1;
    if (t == pair.image_id2 || !graph.HasImage(t) ||
        !scene.shift.count(ImagePair(x, t))) {
      return 0;
    }
    return t;
  }
};

// The street's pairs as seen from their first image, through its
// neighbour one photo away (a true pair).
TEST(ThreeViewConsistency, TruePairsAgreeAndMixedPairsDoNot) {
  Street street;
  const street_test::Scene& scene = street.scene;
  const TrackConsistency& tracks = street.tracks;
  PairGeometryCache& cache = street.cache;
  const ThreeViewOptions options;

  int num_true = 0, num_mixed = 0;
  for (const auto& [pair, shift] : scene.shift) {
    const ImageId x = pair.image_id1;
    const ImageId t = street.ThirdView(pair);
    if (t == 0 || scene.shift.at(ImagePair(x, t)) != 0) continue;
    const ThreeViewResult r = MeasureThreeViewConsistency(
        cache, tracks, *cache.Pair(pair), x, t, options);
    const double true_fraction = scene.true_fraction.at(pair);
    if (shift == 0 && r.judged) {
      ++num_true;
      EXPECT_GT(r.fraction, 0.9) << pair.image_id1 << "-" << pair.image_id2;
      EXPECT_GE(r.num_scale_points, options.min_scale_points);
      EXPECT_LE(r.num_consistent, r.num_shared);
    } else if (shift != 0 && true_fraction > 0.05 && r.judged) {
      // True ground matches fix a scale that the false facade matches
      // contradict.
      ++num_mixed;
      EXPECT_LT(r.fraction, 0.5) << pair.image_id1 << "-" << pair.image_id2
                                 << " true fraction " << true_fraction;
    } else if (shift != 0 && true_fraction == 0.0) {
      // Pure doppelgangers have no distinctive matches to fix the scale.
      EXPECT_FALSE(r.judged);
      EXPECT_EQ(r.fraction, 1.0);
    }
  }
  EXPECT_GE(num_true, 10);
  EXPECT_GE(num_mixed, 3);
}

// An evenly spaced subset of the shared keypoints gives the verdict of all
// of them, at a fraction of the triangulations.
TEST(ThreeViewConsistency, SubsampledSharedPointsKeepTheVerdict) {
  Street street;
  const street_test::Scene& scene = street.scene;
  const TrackConsistency& tracks = street.tracks;
  PairGeometryCache& cache = street.cache;
  ThreeViewOptions all;
  all.max_shared_points = 0;
  ThreeViewOptions sampled;
  sampled.max_shared_points = 40;
  int num_compared = 0;
  for (const auto& [pair, shift] : scene.shift) {
    const ImageId x = pair.image_id1;
    const ImageId t = street.ThirdView(pair);
    if (t == 0) continue;
    const auto xy = cache.Pair(pair);
    const ThreeViewResult full =
        MeasureThreeViewConsistency(cache, tracks, *xy, x, t, all);
    const ThreeViewResult part =
        MeasureThreeViewConsistency(cache, tracks, *xy, x, t, sampled);
    EXPECT_LE(part.num_shared, sampled.max_shared_points);
    EXPECT_EQ(part.judged, full.judged);
    EXPECT_EQ(part.num_scale_points, full.num_scale_points);
    if (!full.judged || full.num_shared < 80) continue;
    ++num_compared;
    EXPECT_LT(part.num_shared, full.num_shared);
    EXPECT_NEAR(part.fraction, full.fraction, 0.15)
        << pair.image_id1 << "-" << pair.image_id2;
    EXPECT_EQ(part.fraction < 0.5, full.fraction < 0.5)
        << pair.image_id1 << "-" << pair.image_id2;
  }
  EXPECT_GE(num_compared, 10);
}

TEST(ThreeViewConsistency, RejectsAnImageOutsideThePair) {
  TempDir dir("hisfm-threeview");
  street_test::Write(dir / "database.db", {6, true, 1});
  Database db(dir / "database.db");
  const TrackConsistency tracks(db, ReadViewGraph(db, 15));
  PairGeometryCache cache(db);
  const auto pair = cache.Pair(ImagePair(1, 2));
  EXPECT_TRUE(pair->has_pose);
  EXPECT_THROW(MeasureThreeViewConsistency(cache, tracks, *pair, 3, 4,
                                           ThreeViewOptions()),
               Error);
  EXPECT_THROW(cache.Pair(ImagePair(1, 99)), Error);
}

}  // namespace
}  // namespace hisfm
