#include "hisfm/verify/track_consistency.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <random>
#include <set>

#include "hisfm/io/database_writer.h"
#include "hisfm/util/test_util.h"
#include "hisfm/verify/street_test_scene.h"
#include "hisfm/verify/view_graph_reader.h"

namespace hisfm {
namespace {

// Three images with five keypoints each. Tracks {1:0, 2:0, 3:0} and
// {1:1, 2:1, 3:1}; pair (1, 3) also matches 1:0 to 3:1, which joins them
// into one track holding keypoints 0 and 1 of images 1 and 3. Track
// {1:2, 3:2} stays consistent; keypoints 3 and 4 are never matched.
void WriteHandMadeDatabase(const std::string& path) {
  DatabaseWriter writer(path);
  writer.WriteCamera(SimplePinholeCamera(1, 100, 100, 100));
  for (ImageId id = 1; id <= 3; ++id) {
    writer.WriteImage({id, "im" + std::to_string(id), 1});
    Keypoints k(5, 2);
    for (int r = 0; r < 5; ++r) k.row(r) << 10.0f * r, 10.0f * r;
    writer.WriteKeypoints(id, k);
  }
  auto write = [&](ImageId a, ImageId b, std::vector<FeatureMatch> m) {
    TwoViewGeometry g;
    g.pair = ImagePair(a, b);
    g.config = static_cast<int>(TwoViewConfig::kCalibrated);
    g.inlier_matches = std::move(m);
    writer.WriteTwoViewGeometry(g);
  };
  write(1, 2, {{0, 0}, {1, 1}});
  write(2, 3, {{0, 0}, {1, 1}});
  write(1, 3, {{0, 1}, {2, 2}});
  writer.Close();
}

TEST(TrackConsistency, MarksTracksWithTwoKeypointsOfOneImage) {
  TempDir dir("hisfm-tracks");
  WriteHandMadeDatabase(dir / "database.db");
  Database db(dir / "database.db");
  const ViewGraph graph = ReadViewGraph(db, 1);
  ASSERT_EQ(graph.NumEdges(), 3u);
  const TrackConsistency tracks(db, graph);
  EXPECT_TRUE(tracks.IsMatched(1, 0));
  EXPECT_FALSE(tracks.IsDistinctive(1, 0));
  EXPECT_FALSE(tracks.IsDistinctive(1, 1));
  EXPECT_FALSE(tracks.IsDistinctive(2, 0));
  EXPECT_FALSE(tracks.IsDistinctive(3, 1));
  EXPECT_TRUE(tracks.IsDistinctive(1, 2));
  EXPECT_TRUE(tracks.IsDistinctive(3, 2));
  EXPECT_FALSE(tracks.IsMatched(1, 3));
  EXPECT_FALSE(tracks.IsDistinctive(1, 4));
  EXPECT_FALSE(tracks.IsMatched(7, 0));   // unknown image
  EXPECT_FALSE(tracks.IsMatched(1, 99));  // unknown keypoint
  EXPECT_NEAR(tracks.DistinctiveFraction(1), 1.0 / 3.0, 1e-12);
  EXPECT_NEAR(tracks.DistinctiveFraction(2), 0.0, 1e-12);
  EXPECT_EQ(tracks.NumMatched(2), 2u);
  EXPECT_NEAR(tracks.InconsistentFraction(), 6.0 / 8.0, 1e-12);

  const TwoViewGeometry g13 = db.ReadTwoViewGeometry(1, 3);
  DistinctiveSupport s = tracks.Support(g13.pair, g13.inlier_matches);
  EXPECT_EQ(s.num_inliers, 2u);
  EXPECT_EQ(s.num_distinctive, 1u);
  EXPECT_NEAR(s.image_fraction, 1.0 / 3.0, 1e-12);  // both images: 1 of 3
  EXPECT_NEAR(s.expected, 2.0 / 3.0, 1e-12);
  EXPECT_NEAR(s.ratio, 1.0, 1e-12);  // 1 found, 2/3 expected: capped
  EXPECT_EQ(s.p_value, 1.0);         // no shortfall
  EXPECT_FALSE(s.Deficient(0.5, 0.01));
  // Pair (1, 2): nothing distinctive expected from image 2.
  const TwoViewGeometry g12 = db.ReadTwoViewGeometry(1, 2);
  s = tracks.Support(g12.pair, g12.inlier_matches);
  EXPECT_EQ(s.expected, 0.0);
  EXPECT_EQ(s.ratio, 1.0);
  EXPECT_EQ(s.p_value, 1.0);
}

// Random matches between random images: every keypoint's state agrees with
// the definition, computed here the slow way (the images each track holds,
// counted per track).
TEST(TrackConsistency, RandomGraphsAgreeWithTheDefinition) {
  for (const uint32_t seed : {1u, 2u, 3u}) {
    TempDir dir("hisfm-tracks");
    std::mt19937 rng(seed);
    const int num_images = 12, num_keypoints = 30;
    std::vector<std::pair<ImagePair, std::vector<FeatureMatch>>> pairs;
    {
      DatabaseWriter writer(dir / "database.db");
      writer.WriteCamera(SimplePinholeCamera(1, 100, 100, 100));
      for (ImageId id = 1; id <= num_images; ++id) {
        writer.WriteImage({id, "im" + std::to_string(id), 1});
        writer.WriteKeypoints(id, Keypoints::Zero(num_keypoints, 2));
      }
      for (ImageId a = 1; a <= num_images; ++a) {
        for (ImageId b = a + 1; b <= num_images; ++b) {
          if (rng() % 3 != 0) continue;
          TwoViewGeometry g;
          g.pair = ImagePair(a, b);
          g.config = static_cast<int>(TwoViewConfig::kCalibrated);
          for (int k = 0; k < 4; ++k) {
            g.inlier_matches.push_back(
                {Point2DIdx(rng() % num_keypoints),
                 Point2DIdx(rng() % num_keypoints)});
          }
          writer.WriteTwoViewGeometry(g);
          pairs.push_back({g.pair, g.inlier_matches});
        }
      }
      writer.Close();
    }
    Database db(dir / "database.db");
    // The read also hands every pair to the observer: its keypoints in the
    // first image are kept for Support without the inliers.
    KeypointMultisets first_keypoints;
    std::map<ImagePair, size_t> multiset_of;
    const TrackConsistency tracks(
        db, ReadViewGraph(db, 1),
        [&](const ImagePair& pair, FeatureMatchSpan inliers) {
          multiset_of[pair] = first_keypoints.Add(num_keypoints, inliers);
        });
    ASSERT_EQ(multiset_of.size(), pairs.size());
    for (const auto& [pair, matches] : pairs) {
      const DistinctiveSupport direct = tracks.Support(pair, matches);
      const DistinctiveSupport kept =
          tracks.Support(pair, static_cast<uint32_t>(matches.size()),
                         first_keypoints, multiset_of.at(pair));
      EXPECT_EQ(kept.num_inliers, direct.num_inliers);
      EXPECT_EQ(kept.num_distinctive, direct.num_distinctive);
      EXPECT_DOUBLE_EQ(kept.p_value, direct.p_value);
    }
    // Slow: label keypoints by track, then collect each track's images.
    auto node = [&](ImageId id, uint32_t k) {
      return static_cast<size_t>(id - 1) * num_keypoints + k;
    };
    const size_t total = static_cast<size_t>(num_images) * num_keypoints;
    std::vector<size_t> label(total);
    for (size_t v = 0; v < total; ++v) label[v] = v;
    std::vector<bool> matched(total, false);
    for (bool changed = true; changed;) {
      changed = false;
      for (const auto& [pair, matches] : pairs) {
        for (const FeatureMatch& m : matches) {
          const size_t u = node(pair.image_id1, m.idx1);
          const size_t v = node(pair.image_id2, m.idx2);
          matched[u] = matched[v] = true;
          const size_t l = std::min(label[u], label[v]);
          changed |= label[u] != l || label[v] != l;
          label[u] = label[v] = l;
        }
      }
    }
    std::map<size_t, std::multiset<ImageId>> images_of_track;
    for (size_t v = 0; v < total; ++v) {
      if (matched[v]) {
        images_of_track[label[v]].insert(
            static_cast<ImageId>(v / num_keypoints + 1));
      }
    }
    size_t num_repeated = 0;
    for (size_t v = 0; v < total; ++v) {
      const ImageId id = static_cast<ImageId>(v / num_keypoints + 1);
      const uint32_t k = static_cast<uint32_t>(v % num_keypoints);
      ASSERT_EQ(tracks.IsMatched(id, k), matched[v]);
      if (!matched[v]) continue;
      const std::multiset<ImageId>& images = images_of_track[label[v]];
      const bool consistent =
          std::set<ImageId>(images.begin(), images.end()).size() ==
          images.size();
      num_repeated += !consistent;
      EXPECT_EQ(tracks.IsDistinctive(id, k), consistent)
          << "seed " << seed << " image " << id << " keypoint " << k;
      EXPECT_EQ(tracks.KeypointsOf(id).IsDistinctive(k), consistent);
    }
    EXPECT_GT(num_repeated, 0u) << "seed " << seed;
  }
}

TEST(DistinctiveSupport, DeficiencyNeedsALargeAndSignificantShortfall) {
  DistinctiveSupport s;
  s.expected = 10;
  s.ratio = 0.0;
  s.p_value = std::exp(-10.0);  // P(X <= 0), X ~ Poisson(10)
  EXPECT_TRUE(s.Deficient(0.5, 0.01));
  s.ratio = 0.6;
  EXPECT_FALSE(s.Deficient(0.5, 0.01));
  s.ratio = 0.2;
  s.p_value = 0.05;
  EXPECT_FALSE(s.Deficient(0.5, 0.01));
}

TEST(TrackConsistency, SeparatesRepeatedFacadesFromUniqueContent) {
  TempDir dir("hisfm-tracks");
  const street_test::Scene scene =
      street_test::Write(dir / "database.db", {16, true, 3});
  Database db(dir / "database.db");
  const ViewGraph graph = ReadViewGraph(db, 15);
  const TrackConsistency tracks(db, graph);
  size_t repeated = 0, repeated_distinctive = 0;
  size_t unique = 0, unique_distinctive = 0;
  for (size_t i = 0; i < scene.point_of_keypoint.size(); ++i) {
    const ImageId id = static_cast<ImageId>(i + 1);
    for (size_t k = 0; k < scene.point_of_keypoint[i].size(); ++k) {
      const int p = scene.point_of_keypoint[i][k];
      if (p < 0 || !tracks.IsMatched(id, static_cast<uint32_t>(k))) continue;
      const bool d = tracks.IsDistinctive(id, static_cast<uint32_t>(k));
      if (scene.repeated[p]) {
        ++repeated;
        repeated_distinctive += d;
      } else {
        ++unique;
        unique_distinctive += d;
      }
    }
  }
  ASSERT_GT(repeated, 1000u);
  ASSERT_GT(unique, 500u);
  EXPECT_LT(static_cast<double>(repeated_distinctive) / repeated, 0.05);
  EXPECT_GT(static_cast<double>(unique_distinctive) / unique, 0.95);

  // Pure doppelgangers (no true inlier) are deficient, true pairs are not;
  // the Poisson tail is exact for a zero count.
  int num_pure = 0;
  for (const auto& [pair, shift] : scene.shift) {
    const TwoViewGeometry g =
        db.ReadTwoViewGeometry(pair.image_id1, pair.image_id2);
    const DistinctiveSupport s = tracks.Support(g.pair, g.inlier_matches);
    if (shift == 0) {
      EXPECT_FALSE(s.Deficient(0.5, 0.01)) << pair.image_id1 << "-"
                                           << pair.image_id2;
      EXPECT_GT(s.ratio, 0.8);
    } else if (scene.true_fraction.at(pair) == 0.0 && s.expected >= 5) {
      ++num_pure;
      EXPECT_EQ(s.num_distinctive, 0u);
      EXPECT_NEAR(s.p_value, std::exp(-s.expected), 1e-9);
      EXPECT_TRUE(s.Deficient(0.5, 0.01));
    }
  }
  EXPECT_GE(num_pure, 20);

  // The same street with unique houses has consistent tracks.
  TempDir control_dir("hisfm-tracks");
  street_test::Write(control_dir / "database.db", {16, false, 3});
  Database control_db(control_dir / "database.db");
  const TrackConsistency control(
      control_db, ReadViewGraph(control_db, 15));
  EXPECT_LT(control.InconsistentFraction(), 0.02);
}

}  // namespace
}  // namespace hisfm
