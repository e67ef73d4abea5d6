// The built-in verifier's score: the probability that a pair the hierarchy
// asks about is true, given what the multi-view edge test
// (edge_consistency.h) measured on it.
//
// The raw evidence is one number in [0, 1]:
//  - when the test judged at least kMinUniquePoints unique points, and the
//    pair's own local models show that detection repeats (a point predicted
//    into a view of its model where it was not matched lands on a keypoint
//    at least kMinRepeatabilityOverChance times as often as a displaced
//    prediction does by chance; otherwise an unmatched point is simply not
//    detected, true pair or not, and missing points say nothing), one minus
//    the share of them that were predicted visible in the other side's
//    images and not found there (missing correspondences);
//  - otherwise (the models did not join, or share no unique content) the
//    pair's burstiness-weighted support relative to the strongest such
//    support of each of its images (match_burstiness.h; the smaller ratio),
//    capped at kMaxSilentRawScore: without a test, a pair as strong as the
//    images' best pairs is probably, not certainly, true.
// Where the test speaks, the probability combines the raw score with two
// more measurements of the pair in a logistic model: how well the pair
// joins the two models (the smaller share of its inliers that are model
// points and agree with the joining depth; a doppelganger of a symmetric
// object joins them with a pose far off, so few agree) and the relative
// burstiness-weighted support (the matches of repeated structure are
// bursty, so a doppelganger is weaker, once burstiness is discounted, than
// each image's strongest pair; Jegou, Douze, Schmid, CVPR 2009). Silent
// pairs are mapped by isotonic regression of the raw score. Both are fitted
// on the tuning half of the synthetic scenes (odd seeds, 40 images, the
// families and the fixed scenes that hold doppelgangers; each instance and
// each class weighted with the share of true pairs among the pairs the
// hierarchy verified there, 0.58):
// `scripts/fit_score_calibration.py` reproduces the model and the table
// from the TSV files of `bench/cue_study`, and docs/decisions.md records
// the fit and the held-out results. The score therefore means the same as
// a learned plug-in's probability, and one threshold
// (--HiSfM.verify_threshold) applies to every verifier.
#pragma once

#include <array>

#include "hisfm/verify/edge_consistency.h"

namespace hisfm {

/// Unique points the edge test needs before it speaks.
constexpr int kMinUniquePoints = 5;
/// How much more often than chance the pair's local models must find their
/// own unmatched points for the test to speak (see the file comment). Twice
/// chance: every instance of the tuning half of the synthetic families
/// shows at least three times chance over its pairs; the fixed synthetic
/// scenes without repeatable detection (`hisfm synth --scene
/// object_control`) show about 1.2.
constexpr double kMinRepeatabilityOverChance = 2.0;
/// Largest raw score of a pair the test could not judge.
constexpr double kMaxSilentRawScore = 0.75;
/// Bins of the silent pairs' calibration table.
constexpr int kScoreBins = 20;

/// What the score is computed from.
struct PairFeatures {
  /// The edge test's counts (EdgeEvidence).
  bool judged = false;
  int num_unique = 0;
  int num_visible = 0;
  int num_found = 0;
  /// Displaced predictions found by chance (EdgeEvidence, over four
  /// displacements) and the models' own consistency counts.
  int num_found_displaced = 0;
  int models_checked = 0;
  int models_found = 0;
  /// How well the pair joins the two models: the smaller of the shares of
  /// its inliers that are model points and agree with the joining depth
  /// (EdgeEvidence::agreement_i, agreement_j), in [0, 1].
  double agreement = 1;
  /// Burstiness-weighted support of the pair relative to the strongest of
  /// each of its images (the smaller ratio, in (0, 1]).
  double relative_burstiness = 1;

  /// The edge test's part from its evidence.
  static PairFeatures FromEvidence(const EdgeEvidence& evidence);
  /// True if the test judged enough unique points where detection repeats.
  bool Speaks() const;
  /// The raw evidence in [0, 1] (see the file comment).
  double RawScore() const;
};

/// Coefficients of the judged pairs' logistic model:
/// P(true) = 1 / (1 + exp(-z)) with z = intercept + raw * RawScore() +
/// agreement * agreement + relative_burstiness * relative_burstiness.
struct JudgedScoreModel {
  /// Log-odds of a pair with all three measurements at 0.
  double intercept = 0;
  /// Weight of PairFeatures::RawScore().
  double raw = 0;
  /// Weight of PairFeatures::agreement (clamped to [0, 1]).
  double agreement = 0;
  /// Weight of PairFeatures::relative_burstiness (clamped to [0, 1]).
  double relative_burstiness = 0;
};

/// The calibrated score in [0, 1]: for judged pairs the logistic model, for
/// silent pairs the silent table.
double CalibratedPairScore(const PairFeatures& features);

/// The logistic model of the pairs the test judged.
const JudgedScoreModel& JudgedModel();

/// The calibration table of silent pairs: P(true) at the centres of
/// kScoreBins equal bins of the raw score.
const std::array<double, kScoreBins>& SilentCalibrationTable();

}  // namespace hisfm
