#include "hisfm/verify/relative_pose.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <random>
#include <utility>
#include <vector>

#include "hisfm/util/error.h"

namespace hisfm {
namespace {

constexpr double kFocal = 800.0;

double Degrees(double radians) { return radians * 180.0 / M_PI; }

double RotationErrorDeg(const Eigen::Quaterniond& a,
                        const Eigen::Quaterniond& b) {
  return Degrees(a.angularDistance(b));
}

double DirectionErrorDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return Degrees(std::acos(
      std::clamp(a.normalized().dot(b.normalized()), -1.0, 1.0)));
}

// Two views of points in front of both: camera 1 at the origin, camera 2 =
// `pose` (unit translation). Inliers carry 0.5 px of noise; the last
// `num_outliers` correspondences are random.
struct TwoViews {
  Rigid3d pose;
  std::vector<Eigen::Vector2d> x1, x2;
  std::vector<bool> outlier;
};

TwoViews MakeTwoViews(uint32_t seed, int num_inliers, int num_outliers) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-1, 1);
  std::normal_distribution<double> noise(0, 0.5 / kFocal);
  TwoViews v;
  // Camera 2 moved sideways and a little forward, turned by ~10 degrees.
  const Eigen::Vector3d center2 =
      Eigen::Vector3d(1.0, 0.1 * u(rng), 0.2 * u(rng)).normalized();
  const Eigen::Quaterniond q(Eigen::AngleAxisd(
      0.15 + 0.05 * u(rng), Eigen::Vector3d(0.1 * u(rng), 1, 0.1 * u(rng))
                                .normalized()));
  v.pose = Rigid3d(q, -(q * center2));
  while (static_cast<int>(v.x1.size()) < num_inliers) {
    const Eigen::Vector3d X(0.5 + 3 * u(rng), 2 * u(rng), 6 + 2 * u(rng));
    const Eigen::Vector3d Y = v.pose * X;
    const Eigen::Vector2d a = X.hnormalized(), b = Y.hnormalized();
    if (Y.z() < 1 || a.cwiseAbs().maxCoeff() > 0.6 ||
        b.cwiseAbs().maxCoeff() > 0.6) {
      continue;
    }
    v.x1.push_back(a + Eigen::Vector2d(noise(rng), noise(rng)));
    v.x2.push_back(b + Eigen::Vector2d(noise(rng), noise(rng)));
    v.outlier.push_back(false);
  }
  for (int k = 0; k < num_outliers; ++k) {
    v.x1.push_back(0.6 * Eigen::Vector2d(u(rng), u(rng)));
    v.x2.push_back(0.6 * Eigen::Vector2d(u(rng), u(rng)));
    v.outlier.push_back(true);
  }
  return v;
}

// Fraction of inliers / outliers that support `pose` (SupportsPose at the
// options' support threshold).
void SupportRates(const TwoViews& v, const Rigid3d& pose,
                  const RelativePoseOptions& options, double* inlier_rate,
                  double* outlier_rate) {
  const Eigen::Matrix3d R = pose.rotation.toRotationMatrix();
  const Eigen::Matrix3d E = EssentialOfPose(pose);
  const double angle_cos =
      std::cos(options.min_cheirality_angle_deg * M_PI / 180.0);
  int in = 0, in_ok = 0, out = 0, out_ok = 0;
  for (size_t k = 0; k < v.x1.size(); ++k) {
    const bool ok =
        SupportsPose(R, pose.translation, E, v.x1[k], v.x2[k],
                     options.support_error_px / kFocal, angle_cos);
    if (v.outlier[k]) {
      ++out;
      out_ok += ok;
    } else {
      ++in;
      in_ok += ok;
    }
  }
  *inlier_rate = in ? double(in_ok) / in : 0;
  *outlier_rate = out ? double(out_ok) / out : 0;
}

TEST(RelativePose, EssentialOfPoseSatisfiesTheEpipolarConstraint) {
  const TwoViews v = MakeTwoViews(1, 50, 0);
  const Eigen::Matrix3d E = EssentialOfPose(v.pose);
  for (size_t k = 0; k < v.x1.size(); ++k) {
    // Normalized residual of a 0.5 px-noisy correspondence.
    EXPECT_LT(std::abs(v.x2[k].homogeneous().dot(E * v.x1[k].homogeneous())),
              10.0 / kFocal);
  }
  // Two equal singular values and a zero one (unit translation).
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(E);
  EXPECT_NEAR(svd.singularValues()(0), 1.0, 1e-9);
  EXPECT_NEAR(svd.singularValues()(1), 1.0, 1e-9);
  EXPECT_NEAR(svd.singularValues()(2), 0.0, 1e-9);
}

TEST(RelativePose, RecoversPoseAndFlagsOutliers) {
  RelativePoseOptions options;
  for (uint32_t seed = 0; seed < 5; ++seed) {
    const TwoViews v = MakeTwoViews(seed, 150, 50);
    options.seed = seed;
    const std::vector<RelativePoseHypothesis> h = EstimateRelativePose(
        EssentialOfPose(v.pose), v.x1, v.x2, kFocal, options);
    ASSERT_FALSE(h.empty());
    ASSERT_LE(h.size(), 2u);
    const Rigid3d& best = h[0].cam2_from_cam1;
    EXPECT_NEAR(best.translation.norm(), 1.0, 1e-9);
    EXPECT_LT(RotationErrorDeg(best.rotation, v.pose.rotation), 0.3)
        << "seed " << seed;
    EXPECT_LT(DirectionErrorDeg(best.translation, v.pose.translation), 2.0)
        << "seed " << seed;
    double inlier_rate = 0, outlier_rate = 0;
    SupportRates(v, best, options, &inlier_rate, &outlier_rate);
    EXPECT_GT(inlier_rate, 0.9) << "seed " << seed;
    EXPECT_LT(outlier_rate, 0.15) << "seed " << seed;
    // num_support counts the supporting correspondences (up to the
    // rounding of the returned pose, on borderline ones).
    EXPECT_NEAR(h[0].num_support, inlier_rate * 150 + outlier_rate * 50, 2)
        << "seed " << seed;
    // The other hypothesis, if any, has the other translation sign and
    // less support.
    if (h.size() == 2) {
      EXPECT_LT(h[1].cam2_from_cam1.translation.dot(best.translation), 0);
      EXPECT_LE(h[1].num_support, h[0].num_support);
      EXPECT_LT(h[1].num_support, 75);
    }
  }
}

TEST(RelativePose, WrongPriorRotationIsCorrectedByTheEightPointSamples) {
  RelativePoseOptions options;
  const TwoViews v = MakeTwoViews(21, 150, 30);
  // A prior 5 degrees off in rotation and 20 degrees off in translation.
  const Eigen::Quaterniond dq(
      Eigen::AngleAxisd(5 * M_PI / 180, Eigen::Vector3d(0, 0, 1)));
  const Eigen::Vector3d t_wrong =
      Eigen::AngleAxisd(20 * M_PI / 180, Eigen::Vector3d(0, 1, 0)) *
      v.pose.translation;
  const Rigid3d prior(dq * v.pose.rotation, t_wrong);
  const std::vector<RelativePoseHypothesis> h =
      EstimateRelativePose(EssentialOfPose(prior), v.x1, v.x2, kFocal, options);
  ASSERT_FALSE(h.empty());
  EXPECT_LT(RotationErrorDeg(h[0].cam2_from_cam1.rotation, v.pose.rotation),
            0.5);
  EXPECT_LT(DirectionErrorDeg(h[0].cam2_from_cam1.translation,
                              v.pose.translation),
            3.0);
  EXPECT_GT(h[0].num_support, 130);
}

TEST(RelativePose, DoppelgangerGroupGetsTheOtherTranslationSign) {
  // Camera 2 one unit along +x from camera 1, same orientation. True
  // matches, and matches to a copy of the structure 4 units further along
  // the baseline: both satisfy the same epipolar geometry, the copy's as if
  // camera 2 stood at -3 (the reversed baseline).
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> u(-1, 1);
  std::normal_distribution<double> noise(0, 0.3 / kFocal);
  const Eigen::Vector3d c2(1, 0, 0);
  const Rigid3d pose(Eigen::Quaterniond::Identity(), -c2);
  std::vector<Eigen::Vector2d> x1, x2;
  int num_true = 0, num_copy = 0;
  while (num_true + num_copy < 180) {
    const bool copy = num_true + num_copy >= 120;
    const Eigen::Vector3d X(3 * u(rng), 2 * u(rng), 6 + 2 * u(rng));
    const Eigen::Vector3d Y =
        X - c2 + (copy ? Eigen::Vector3d(4, 0, 0) : Eigen::Vector3d::Zero());
    if (Y.z() < 1 || X.hnormalized().cwiseAbs().maxCoeff() > 0.7 ||
        Y.hnormalized().cwiseAbs().maxCoeff() > 0.7) {
      continue;
    }
    x1.push_back(X.hnormalized() + Eigen::Vector2d(noise(rng), noise(rng)));
    x2.push_back(Y.hnormalized() + Eigen::Vector2d(noise(rng), noise(rng)));
    (copy ? num_copy : num_true)++;
  }
  RelativePoseOptions options;
  const std::vector<RelativePoseHypothesis> h =
      EstimateRelativePose(EssentialOfPose(pose), x1, x2, kFocal, options);
  ASSERT_EQ(h.size(), 2u);
  const Eigen::Vector3d t_true = pose.translation.normalized();
  EXPECT_LT(DirectionErrorDeg(h[0].cam2_from_cam1.translation, t_true), 2.0);
  EXPECT_LT(DirectionErrorDeg(h[1].cam2_from_cam1.translation, -t_true), 3.0);
  EXPECT_NEAR(h[0].num_support, num_true, 6);
  EXPECT_NEAR(h[1].num_support, num_copy, 6);
}

TEST(RelativePose, TooFewOrDegenerateInputsGiveNothing) {
  const TwoViews v = MakeTwoViews(2, 20, 0);
  const Eigen::Matrix3d E = EssentialOfPose(v.pose);
  RelativePoseOptions options;
  const std::vector<Eigen::Vector2d> four1(v.x1.begin(), v.x1.begin() + 4);
  const std::vector<Eigen::Vector2d> four2(v.x2.begin(), v.x2.begin() + 4);
  EXPECT_TRUE(EstimateRelativePose(E, four1, four2, kFocal, options).empty());
  EXPECT_TRUE(EstimateRelativePose(Eigen::Matrix3d::Zero(), v.x1, v.x2, kFocal,
                                   options)
                  .empty());
  Eigen::Matrix3d nan_E = E;
  nan_E(1, 1) = std::nan("");
  EXPECT_TRUE(EstimateRelativePose(nan_E, v.x1, v.x2, kFocal, options).empty());
  EXPECT_TRUE(EstimateRelativePose(E, v.x1, v.x2, 0.0, options).empty());
  std::vector<Eigen::Vector2d> shorter = v.x2;
  shorter.pop_back();
  EXPECT_TRUE(EstimateRelativePose(E, v.x1, shorter, kFocal, options).empty());
  // Five exact correspondences are enough to return something.
  const std::vector<Eigen::Vector2d> five1(v.x1.begin(), v.x1.begin() + 5);
  const std::vector<Eigen::Vector2d> five2(v.x2.begin(), v.x2.begin() + 5);
  EXPECT_FALSE(EstimateRelativePose(E, five1, five2, kFocal, options).empty());
}

TEST(RelativePose, SameSeedSameResult) {
  const TwoViews v = MakeTwoViews(9, 80, 40);
  RelativePoseOptions options;
  options.seed = 17;
  const auto a = EstimateRelativePose(EssentialOfPose(v.pose), v.x1, v.x2,
                                      kFocal, options);
  const auto b = EstimateRelativePose(EssentialOfPose(v.pose), v.x1, v.x2,
                                      kFocal, options);
  ASSERT_EQ(a.size(), b.size());
  for (size_t k = 0; k < a.size(); ++k) {
    EXPECT_EQ(a[k].num_support, b[k].num_support);
    EXPECT_EQ(a[k].cam2_from_cam1.translation, b[k].cam2_from_cam1.translation);
    EXPECT_EQ(a[k].cam2_from_cam1.rotation.coeffs(),
              b[k].cam2_from_cam1.rotation.coeffs());
  }
}

TEST(SupportsPose, EpipolarDistanceAndCheirality) {
  const Eigen::Vector3d c2(1, 0, 0);
  const Eigen::Matrix3d R = Eigen::Matrix3d::Identity();
  const Eigen::Vector3d t = -c2;
  const Eigen::Matrix3d E = EssentialOfPose(Rigid3d(Eigen::Quaterniond::Identity(), t));
  const double max_error = 2.0 / kFocal;
  const double angle_cos = std::cos(0.5 * M_PI / 180.0);
  const Eigen::Vector3d X(0.2, 0.1, 5);
  const Eigen::Vector2d x1 = X.hnormalized(), x2 = (X - c2).hnormalized();
  EXPECT_TRUE(SupportsPose(R, t, E, x1, x2, max_error, angle_cos));
  // Off the epipolar line (horizontal here) by 5 px.
  EXPECT_FALSE(SupportsPose(R, t, E, x1, x2 + Eigen::Vector2d(0, 5 / kFocal),
                            max_error, angle_cos));
  // Within 1 px: still supports.
  EXPECT_TRUE(SupportsPose(R, t, E, x1, x2 + Eigen::Vector2d(0, 1 / kFocal),
                           max_error, angle_cos));
  // The reversed baseline: same epipolar geometry, behind the cameras.
  EXPECT_FALSE(SupportsPose(R, -t, -E, x1, x2, max_error, angle_cos));
  // A very distant point (rays nearly parallel) is neutral: it supports
  // both signs.
  const Eigen::Vector3d far(0.2, 0.1, 1e4);
  const Eigen::Vector2d f1 = far.hnormalized(), f2 = (far - c2).hnormalized();
  EXPECT_TRUE(SupportsPose(R, t, E, f1, f2, max_error, angle_cos));
  EXPECT_TRUE(SupportsPose(R, -t, -E, f1, f2, max_error, angle_cos));
}

// Reference counts of (R, t) and (R, -t), one SupportsPose call each.
std::pair<int, int> CountWithSupportsPose(const Eigen::Matrix3d& R,
                                          const Eigen::Vector3d& t,
                                          const TwoViews& v, double max_error,
                                          double angle_cos) {
  const Eigen::Matrix3d E =
      EssentialOfPose(Rigid3d(Eigen::Quaterniond(R), t));
  std::pair<int, int> counts{0, 0};
  for (size_t k = 0; k < v.x1.size(); ++k) {
    counts.first += SupportsPose(R, t, E, v.x1[k], v.x2[k], max_error, angle_cos);
    counts.second +=
        SupportsPose(R, -t, -E, v.x1[k], v.x2[k], max_error, angle_cos);
  }
  return counts;
}

TEST(CountSupportBothSigns, EqualsTwoSeparateCountsAndStopsOnlyWhenNoneCanWin) {
  const double max_error = 2.0 / kFocal;
  const double angle_cos = std::cos(0.5 * M_PI / 180.0);
  int compared = 0;
  for (uint32_t seed = 1; seed <= 5; ++seed) {
    // Points in front (true sign), random outliers, and distant points
    // whose rays are nearly parallel (neutral: they support both signs).
    TwoViews v = MakeTwoViews(seed, 60, 30);
    for (int k = 0; k < 5; ++k) {
      const Eigen::Vector3d far(0.1 * k, -0.05 * k, 1e5);
      v.x1.push_back(far.hnormalized());
      v.x2.push_back((v.pose * far).hnormalized());
    }
    const Eigen::Matrix3d R = v.pose.rotation.toRotationMatrix();
    std::mt19937 rng(seed);
    std::normal_distribution<double> n(0, 0.05);
    for (int trial = 0; trial < 6; ++trial) {
      // The true translation, then perturbed ones (fewer supporters).
      const Eigen::Vector3d t =
          (v.pose.translation +
           (trial == 0 ? Eigen::Vector3d::Zero()
                       : Eigen::Vector3d(n(rng), n(rng), n(rng))))
              .normalized();
      const auto [want_plus, want_minus] =
          CountWithSupportsPose(R, t, v, max_error, angle_cos);
      int plus = -1, minus = -1;
      CountSupportBothSigns(R, t, v.x1, v.x2, max_error, angle_cos, -1, -1,
                            &plus, &minus);
      EXPECT_EQ(plus, want_plus);
      EXPECT_EQ(minus, want_minus);
      if (trial == 0) {
        EXPECT_GT(plus, 50);  // The true sign: the inliers and far points.
        EXPECT_LT(minus, 10);  // The other sign: only the far points.
      }
      // Bounds: a count that can exceed its bound is exact; one that
      // cannot is at most its bound.
      for (const int bound_plus : {-1, want_plus - 1, want_plus, want_plus + 5}) {
        for (const int bound_minus : {-1, want_minus - 1, want_minus}) {
          CountSupportBothSigns(R, t, v.x1, v.x2, max_error, angle_cos,
                                bound_plus, bound_minus, &plus, &minus);
          if (want_plus > bound_plus) {
            EXPECT_EQ(plus, want_plus);
          } else {
            EXPECT_LE(plus, bound_plus);
          }
          if (want_minus > bound_minus) {
            EXPECT_EQ(minus, want_minus);
          } else {
            EXPECT_LE(minus, bound_minus);
          }
          ++compared;
        }
      }
    }
  }
  EXPECT_EQ(compared, 5 * 6 * 12);
}

TEST(RelativePoseOptions, CheckRejectsOutOfRangeValues) {
  EXPECT_NO_THROW(RelativePoseOptions().Check());
  auto expect_throw = [](auto modify) {
    RelativePoseOptions o;
    modify(o);
    EXPECT_THROW(o.Check(), Error);
  };
  expect_throw([](RelativePoseOptions& o) { o.max_error_px = 0; });
  expect_throw([](RelativePoseOptions& o) { o.support_error_px = -1; });
  expect_throw([](RelativePoseOptions& o) { o.num_samples = 0; });
  expect_throw([](RelativePoseOptions& o) { o.num_eight_point_samples = -1; });
  expect_throw([](RelativePoseOptions& o) { o.num_refinements = -1; });
  expect_throw([](RelativePoseOptions& o) { o.min_cheirality_angle_deg = 90; });
  expect_throw([](RelativePoseOptions& o) { o.min_cheirality_angle_deg = -1; });
}

}  // namespace
}  // namespace hisfm
