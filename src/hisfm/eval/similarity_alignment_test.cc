#include "hisfm/eval/similarity_alignment.h"

#include <gtest/gtest.h>

#include <random>

#include "hisfm/util/error.h"

namespace hisfm {
namespace {

Sim3d RandomSimilarity(std::mt19937* rng) {
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  Sim3d sim;
  sim.scale = std::exp(2.0 * uniform(*rng));
  sim.rotation = Eigen::Quaterniond(uniform(*rng), uniform(*rng),
                                    uniform(*rng), uniform(*rng))
                     .normalized();
  sim.translation =
      10.0 * Eigen::Vector3d(uniform(*rng), uniform(*rng), uniform(*rng));
  return sim;
}

std::vector<Eigen::Vector3d> RandomPoints(size_t n, std::mt19937* rng) {
  std::uniform_real_distribution<double> uniform(-5.0, 5.0);
  std::vector<Eigen::Vector3d> points;
  for (size_t i = 0; i < n; ++i) {
    points.emplace_back(uniform(*rng), uniform(*rng), uniform(*rng));
  }
  return points;
}

void ExpectSimilar(const Sim3d& a, const Sim3d& b, double tolerance) {
  EXPECT_NEAR(a.scale, b.scale, tolerance * b.scale);
  EXPECT_LT(a.rotation.angularDistance(b.rotation), tolerance);
  EXPECT_LT((a.translation - b.translation).norm(),
            tolerance * (1.0 + b.translation.norm()));
}

TEST(Sim3d, InverseAndPoseTransform) {
  std::mt19937 rng(3);
  const Sim3d sim = RandomSimilarity(&rng);
  const Eigen::Vector3d x(1.0, -2.0, 0.5);
  EXPECT_LT((sim.Inverse() * (sim * x) - x).norm(), 1e-9);
  EXPECT_LT((sim.ToMatrix() * x.homogeneous() - sim * x).norm(), 1e-9);
  // A camera keeps seeing the same (scaled) point after the transform.
  const Rigid3d cam_from_a(
      Eigen::Quaterniond(0.3, -0.5, 0.2, 0.8).normalized(),
      Eigen::Vector3d(0.4, 1.0, -3.0));
  const Rigid3d cam_from_b = sim.TransformPose(cam_from_a);
  EXPECT_LT(((cam_from_b * (sim * x)) - sim.scale * (cam_from_a * x)).norm(),
            1e-9);
  const Eigen::Vector3d center_a = cam_from_a.Inverse().translation;
  EXPECT_LT((cam_from_b.Inverse().translation - sim * center_a).norm(), 1e-9);
}

TEST(SimilarityAlignment, LeastSquaresRecoversExactSimilarity) {
  std::mt19937 rng(5);
  const Sim3d truth = RandomSimilarity(&rng);
  const std::vector<Eigen::Vector3d> source = RandomPoints(10, &rng);
  std::vector<Eigen::Vector3d> target;
  for (const auto& p : source) target.push_back(truth * p);
  Sim3d estimate;
  ASSERT_TRUE(EstimateSimilarity(source, target, &estimate));
  ExpectSimilar(estimate, truth, 1e-9);
  // Degenerate inputs.
  EXPECT_FALSE(EstimateSimilarity({source[0], source[1]},
                                  {target[0], target[1]}, &estimate));
  EXPECT_FALSE(EstimateSimilarity({source[0], source[0], source[0]},
                                  {target[0], target[1], target[2]},
                                  &estimate));
}

TEST(SimilarityAlignment, RobustToThirtyPercentOutliers) {
  std::mt19937 rng(11);
  for (int trial = 0; trial < 5; ++trial) {
    const Sim3d truth = RandomSimilarity(&rng);
    const size_t n = 60;
    const std::vector<Eigen::Vector3d> source = RandomPoints(n, &rng);
    std::vector<Eigen::Vector3d> target;
    std::normal_distribution<double> noise(0.0, 1e-4);
    for (const auto& p : source) {
      target.push_back(truth * p +
                       truth.scale * Eigen::Vector3d(noise(rng), noise(rng),
                                                     noise(rng)));
    }
    // 30% of the targets are moved far from where they belong.
    std::vector<bool> is_outlier(n, false);
    std::uniform_real_distribution<double> uniform(-1.0, 1.0);
    for (size_t i = 0; i < n; i += 10) {
      for (size_t k = i; k < i + 3; ++k) {
        is_outlier[k] = true;
        target[k] += truth.scale *
                     Eigen::Vector3d(3.0 + uniform(rng), 4.0 * uniform(rng),
                                     -3.0 + uniform(rng));
      }
    }
    SimilarityAlignmentOptions options;
    options.random_seed = 100 + trial;
    const SimilarityAlignment result =
        AlignSimilarityRobust(source, target, options);
    ASSERT_TRUE(result.success);
    ExpectSimilar(result.target_from_source, truth, 1e-3);
    EXPECT_EQ(result.num_inliers, n - 18);
    for (size_t i = 0; i < n; ++i) {
      EXPECT_EQ(result.inliers[i], !is_outlier[i]) << "point " << i;
    }
    // Plain least squares on all points is pulled away by the outliers.
    Sim3d least_squares;
    ASSERT_TRUE(EstimateSimilarity(source, target, &least_squares));
    EXPECT_GT((least_squares.translation - truth.translation).norm(),
              10 * (result.target_from_source.translation - truth.translation)
                       .norm());
  }
}

TEST(SimilarityAlignment, FailsWithoutEnoughPoints) {
  std::mt19937 rng(2);
  const std::vector<Eigen::Vector3d> points = RandomPoints(2, &rng);
  const SimilarityAlignment result =
      AlignSimilarityRobust(points, points, SimilarityAlignmentOptions());
  EXPECT_FALSE(result.success);
  EXPECT_EQ(result.inliers.size(), 2u);
  EXPECT_EQ(result.num_inliers, 0u);
  const std::vector<Eigen::Vector3d> same(5, Eigen::Vector3d(1, 2, 3));
  EXPECT_FALSE(
      AlignSimilarityRobust(same, same, SimilarityAlignmentOptions()).success);
}

TEST(SimilarityAlignment, EachCorrespondenceHasItsOwnInlierDistance) {
  std::mt19937 rng(5);
  const Sim3d truth = RandomSimilarity(&rng);
  const std::vector<Eigen::Vector3d> source = RandomPoints(40, &rng);
  std::vector<Eigen::Vector3d> target;
  for (const Eigen::Vector3d& p : source) target.push_back(truth * p);
  // Two points off by 1 unit: one with a loose distance (an inlier), one
  // with a tight one (an outlier); the others are exact.
  std::vector<double> distances(source.size(), 0.1);
  target[3] += Eigen::Vector3d(1, 0, 0);
  distances[3] = 2.0;
  target[7] += Eigen::Vector3d(0, 1, 0);
  const SimilarityAlignment result = AlignSimilarityRobust(
      source, target, distances, SimilarityAlignmentOptions());
  ASSERT_TRUE(result.success);
  EXPECT_TRUE(result.inliers[3]);
  EXPECT_FALSE(result.inliers[7]);
  EXPECT_EQ(result.num_inliers, source.size() - 1);
  EXPECT_EQ(result.inlier_distance, 0.0);
  distances[0] = 0.0;
  EXPECT_THROW(AlignSimilarityRobust(source, target, distances,
                                     SimilarityAlignmentOptions()),
               Error);
  distances.pop_back();
  EXPECT_THROW(AlignSimilarityRobust(source, target, distances,
                                     SimilarityAlignmentOptions()),
               Error);
}

TEST(SimilarityAlignment, OptionsAreChecked) {
  SimilarityAlignmentOptions options;
  options.inlier_threshold = 0.0;
  EXPECT_THROW(options.Check(), Error);
  options = SimilarityAlignmentOptions();
  options.num_iterations = 0;
  EXPECT_THROW(options.Check(), Error);
  EXPECT_NO_THROW(SimilarityAlignmentOptions().Check());
}

}  // namespace
}  // namespace hisfm
