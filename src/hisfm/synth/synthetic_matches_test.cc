#include "hisfm/synth/synthetic_matches.h"

#include <gtest/gtest.h>

#include <cmath>
#include <set>

namespace hisfm {
namespace {

constexpr double kRadToDeg = 180.0 / M_PI;

SynthOptions Options(const std::string& scene, int num_images) {
  SynthOptions options;
  options.scene = scene;
  options.num_images = num_images;
  options.seed = 11;
  options.num_threads = 2;
  return options;
}

std::vector<SynthPair> AllPairs(const SyntheticScene& scene) {
  std::vector<SynthPair> pairs;
  ForEachSynthPair(scene, true, [&](const SynthPair& p) { pairs.push_back(p); });
  return pairs;
}

// Angle between the stored relative rotation and the true one, and between
// the stored and true translation directions (degrees).
std::pair<double, double> PoseErrors(const SyntheticScene& scene,
                                     const SynthPair& pair) {
  const Rigid3d truth = SynthHypothesisPose(
      scene, pair.matches.pair.image_id1, pair.matches.pair.image_id2, 0);
  const Eigen::Vector4d& q = pair.verification.geometry.qvec;
  const Eigen::Quaterniond stored(q(0), q(1), q(2), q(3));
  const double rotation_error = stored.angularDistance(truth.rotation) * kRadToDeg;
  const double cosine = std::clamp(
      truth.translation.normalized().dot(pair.verification.geometry.tvec), -1.0,
      1.0);
  return {rotation_error, std::acos(cosine) * kRadToDeg};
}

TEST(SyntheticMatches, MatchesAreOneToOneAndLabelled) {
  const SyntheticScene scene = GenerateScene(Options("symmetric4", 16));
  const std::vector<SynthPair> pairs = AllPairs(scene);
  ASSERT_FALSE(pairs.empty());
  size_t num_outliers = 0, num_matches = 0;
  for (const SynthPair& pair : pairs) {
    const SynthPairMatches& m = pair.matches;
    ASSERT_LT(m.pair.image_id1, m.pair.image_id2);
    ASSERT_EQ(m.matches.size(), m.labels.size());
    std::set<uint32_t> used1, used2;
    for (size_t k = 0; k < m.matches.size(); ++k) {
      EXPECT_TRUE(used1.insert(m.matches[k].idx1).second);
      EXPECT_TRUE(used2.insert(m.matches[k].idx2).second);
      const SynthFeature& f1 = scene.images[m.pair.image_id1 - 1].features[m.matches[k].idx1];
      const SynthFeature& f2 = scene.images[m.pair.image_id2 - 1].features[m.matches[k].idx2];
      if (m.labels[k] == kOutlierMatchLabel) {
        ++num_outliers;
        continue;
      }
      const ScenePoint& p1 = scene.layout.points[f1.point_index];
      const ScenePoint& p2 = scene.layout.points[f2.point_index];
      EXPECT_EQ(p1.appearance, p2.appearance);
      // The label is the symmetry relating the two observed points.
      const Rigid3d g = scene.layout.symmetry.Transform(m.labels[k]);
      EXPECT_LT((g * p1.xyz - p2.xyz).norm(), 1e-9);
    }
    num_matches += m.matches.size();
  }
  const double outlier_fraction = static_cast<double>(num_outliers) / num_matches;
  EXPECT_GT(outlier_fraction, 0.01);
  EXPECT_LT(outlier_fraction, 0.06);
}

TEST(SyntheticMatches, VerifiedGeometryExplainsItsInliers) {
  const SyntheticScene scene = GenerateScene(Options("symmetric2", 16));
  size_t verified = 0;
  for (const SynthPair& pair : AllPairs(scene)) {
    const SynthVerification& v = pair.verification;
    if (!v.verified) continue;
    ++verified;
    const TwoViewGeometry& g = v.geometry;
    EXPECT_EQ(g.config, static_cast<int>(TwoViewConfig::kCalibrated));
    EXPECT_GE(g.inlier_matches.size(), 15u);
    EXPECT_NEAR(g.tvec.norm(), 1.0, 1e-9);
    const Eigen::Matrix3d K_inv = scene.K.inverse();
    const SynthImage& image1 = scene.images[g.pair.image_id1 - 1];
    const SynthImage& image2 = scene.images[g.pair.image_id2 - 1];
    for (const FeatureMatch& m : g.inlier_matches) {
      const Eigen::Vector3d x1 =
          K_inv * image1.features[m.idx1].xy.cast<double>().homogeneous();
      const Eigen::Vector3d x2 =
          K_inv * image2.features[m.idx2].xy.cast<double>().homogeneous();
      // Epipolar residual in normalised coordinates, about 4 px / f at most.
      const Eigen::Vector3d line = g.E * x1;
      EXPECT_LT(std::abs(x2.dot(line)) / line.head<2>().norm(),
                8.0 / scene.options.focal_length);
    }
  }
  EXPECT_GT(verified, 30u);
}

TEST(SyntheticMatches, SymmetricScenesContainDoppelgangerPairs) {
  for (const std::string scene_name : {"symmetric2", "symmetric4", "street"}) {
    const SyntheticScene scene =
        GenerateScene(Options(scene_name, scene_name == "street" ? 30 : 24));
    size_t verified = 0, doppelgangers = 0, far_off = 0;
    for (const SynthPair& pair : AllPairs(scene)) {
      if (!pair.verification.verified) continue;
      ++verified;
      const auto [rotation_error, translation_error] = PoseErrors(scene, pair);
      const bool off = rotation_error > 30.0 || translation_error > 30.0;
      if (pair.verification.IsDoppelganger()) {
        ++doppelgangers;
        // The inliers are doppelganger matches, not true ones.
        EXPECT_LT(pair.verification.num_true_inliers,
                  pair.verification.geometry.inlier_matches.size() / 2);
      }
      if (off) {
        ++far_off;
        EXPECT_TRUE(pair.verification.IsDoppelganger());
        EXPECT_GE(pair.verification.geometry.inlier_matches.size(), 15u);
      }
    }
    EXPECT_GT(far_off, verified / 10) << scene_name;
    EXPECT_GE(doppelgangers, far_off) << scene_name;
  }
}

TEST(SyntheticMatches, ControlScenesContainNoDoppelgangerPairs) {
  for (const std::string scene_name : {"object_control", "street_control"}) {
    const SyntheticScene scene = GenerateScene(Options(scene_name, 24));
    size_t verified = 0;
    for (const SynthPair& pair : AllPairs(scene)) {
      EXPECT_EQ(pair.matches.NumDoppelgangerMatches(), 0u);
      if (!pair.verification.verified) continue;
      ++verified;
      EXPECT_FALSE(pair.verification.IsDoppelganger());
      const auto [rotation_error, translation_error] = PoseErrors(scene, pair);
      EXPECT_LT(rotation_error, 1e-4);
      EXPECT_LT(translation_error, 1e-4);
    }
    EXPECT_GT(verified, 50u) << scene_name;
  }
}

size_t NumVerifiedPairs(const std::string& scene_name, int num_images) {
  const SyntheticScene scene = GenerateScene(Options(scene_name, num_images));
  size_t verified = 0;
  for (const SynthPair& pair : AllPairs(scene)) {
    if (pair.verification.verified) ++verified;
  }
  return verified;
}

TEST(SyntheticMatches, NumberOfPairsGrowsAsExpected) {
  // A ring: each camera pairs with a fixed fraction of the ring (quadratic).
  const double ring_ratio = static_cast<double>(NumVerifiedPairs("symmetric2", 32)) /
                            NumVerifiedPairs("symmetric2", 16);
  EXPECT_GT(ring_ratio, 3.3);
  EXPECT_LT(ring_ratio, 5.0);
  // A long street: each camera pairs with the cameras of its block (linear).
  const double street_ratio =
      static_cast<double>(NumVerifiedPairs("street", 240)) /
      NumVerifiedPairs("street", 120);
  EXPECT_GT(street_ratio, 1.6);
  EXPECT_LT(street_ratio, 2.4);
}

TEST(SyntheticMatches, DeterministicMatches) {
  const SynthOptions options = Options("symmetric2", 12);
  const SyntheticScene a = GenerateScene(options);
  SynthOptions one_thread = options;
  one_thread.num_threads = 1;
  const SyntheticScene b = GenerateScene(one_thread);
  const std::vector<SynthPair> pa = AllPairs(a);
  const std::vector<SynthPair> pb = AllPairs(b);
  ASSERT_EQ(pa.size(), pb.size());
  for (size_t i = 0; i < pa.size(); ++i) {
    ASSERT_EQ(pa[i].matches.pair, pb[i].matches.pair);
    ASSERT_EQ(pa[i].matches.matches.size(), pb[i].matches.matches.size());
    for (size_t k = 0; k < pa[i].matches.matches.size(); ++k) {
      EXPECT_EQ(pa[i].matches.matches[k].idx1, pb[i].matches.matches[k].idx1);
      EXPECT_EQ(pa[i].matches.matches[k].idx2, pb[i].matches.matches[k].idx2);
    }
    EXPECT_EQ(pa[i].verification.geometry.inlier_matches.size(),
              pb[i].verification.geometry.inlier_matches.size());
  }
}

}  // namespace
}  // namespace hisfm
