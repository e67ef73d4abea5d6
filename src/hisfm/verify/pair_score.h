// The built-in verifier's calibrated score: the probability that a pair is
// true given what the multi-view edge test (edge_consistency.h) and the
// pair's support measured, by a logistic model.
//
// Features (each scale-free, so that no threshold depends on the scene's
// size, resolution or matcher density):
//  - the edge test, when it judged at least min_unique_points unique points:
//    the share of them predicted visible in the other side's images but not
//    found there, the log of their number, an indicator that it judged, and
//    how well the pair's inliers agree with both models' depths;
//  - the pair's burstiness-weighted support (match_burstiness.h) relative to
//    the strongest such support of each of its two images (the smaller of
//    the two ratios), and its log: a doppelganger joins two images through
//    repeated structure only and is weak next to their true neighbours;
//  - the same ratio of raw inlier counts.
// The coefficients were fitted by weighted logistic regression (each scene
// instance and each class weighing the same) on the tuning half of the
// synthetic families (odd seeds, 40 and 150 images; `bench/verifier_study
// --fit`); docs/decisions.md has the fit and the held-out results.
#pragma once

#include <array>

#include "hisfm/verify/edge_consistency.h"

namespace hisfm {

/// What the score is computed from.
struct PairFeatures {
  /// The edge test's counts (EdgeEvidence).
  bool judged = false;
  int num_unique = 0;
  int num_visible = 0;
  int num_found = 0;
  double agreement = 0;  ///< min(agreement_i, agreement_j)
  /// Burstiness-weighted and raw support of the pair relative to the
  /// strongest of each of its images (the smaller ratio, in (0, 1]).
  double relative_burstiness = 1;
  double relative_inliers = 1;

  /// The edge test's part from its evidence.
  static PairFeatures FromEvidence(const EdgeEvidence& evidence);
};

/// Unique points the edge test needs before it speaks.
constexpr int kMinUniquePoints = 5;

/// The feature vector of the logistic model (first entry: 1 for the bias).
std::array<double, 8> ScoreFeatureVector(const PairFeatures& features);

/// The calibrated score in (0, 1).
double CalibratedPairScore(const PairFeatures& features);

/// The model's coefficients, in the order of ScoreFeatureVector.
const std::array<double, 8>& PairScoreCoefficients();

}  // namespace hisfm
