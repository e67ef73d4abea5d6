#include "hisfm/verify/pair_score.h"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace hisfm {
namespace {

// A judged pair whose local models show repeatable detection (half of
// their own checked points found, nothing found by chance).
PairFeatures Judged(int num_unique, int num_visible, int num_found) {
  PairFeatures f;
  f.judged = true;
  f.num_unique = num_unique;
  f.num_visible = num_visible;
  f.num_found = num_found;
  f.models_checked = 10;
  f.models_found = 5;
  return f;
}

PairFeatures Silent(double relative_burstiness) {
  PairFeatures f;
  f.relative_burstiness = relative_burstiness;
  return f;
}

TEST(PairScore, SilentTableIsAMonotoneProbability) {
  const auto& table = SilentCalibrationTable();
  for (int k = 0; k < kScoreBins; ++k) {
    EXPECT_GE(table[k], 0.0);
    EXPECT_LE(table[k], 1.0);
    if (k > 0) {
      EXPECT_GE(table[k], table[k - 1]) << "bin " << k;
    }
  }
  // The table says something: the best bin is more likely true than the
  // worst.
  EXPECT_GT(table[kScoreBins - 1], table[0]);
}

TEST(PairScore, JudgedModelRewardsEveryMeasurement) {
  // Each measurement is evidence for a true pair: none of the fitted
  // coefficients may be negative, and the raw score must matter.
  const JudgedScoreModel& m = JudgedModel();
  EXPECT_GT(m.raw, 0.0);
  EXPECT_GE(m.agreement, 0.0);
  EXPECT_GE(m.relative_burstiness, 0.0);
}

// A judged pair with raw score 0.6 (16 of 40 unique points missing).
PairFeatures Raw06(double agreement, double relative_burstiness) {
  PairFeatures f = Judged(40, 16, 0);
  f.agreement = agreement;
  f.relative_burstiness = relative_burstiness;
  return f;
}

TEST(PairScore, JudgedScoreIsTheLogisticModel) {
  const JudgedScoreModel& m = JudgedModel();
  for (const double agreement : {0.0, 0.3, 1.0}) {
    for (const double burstiness : {0.05, 0.5, 1.0}) {
      const double z = m.intercept + m.raw * 0.6 + m.agreement * agreement +
                       m.relative_burstiness * burstiness;
      EXPECT_NEAR(CalibratedPairScore(Raw06(agreement, burstiness)),
                  1 / (1 + std::exp(-z)), 1e-12)
          << agreement << " " << burstiness;
    }
  }
  // Out-of-range measurements are clamped to [0, 1].
  EXPECT_DOUBLE_EQ(CalibratedPairScore(Raw06(1.7, -0.2)),
                   CalibratedPairScore(Raw06(1.0, 0.0)));
}

TEST(PairScore, PoorJoinOrBurstySupportLowersTheScore) {
  // The same missing correspondences: a pair that joins its models badly
  // (few inliers at the models' depth) or whose support is bursty (weak
  // once repeated matches are discounted) is less likely true.
  EXPECT_GT(CalibratedPairScore(Raw06(1.0, 1.0)),
            CalibratedPairScore(Raw06(0.3, 1.0)));
  EXPECT_GT(CalibratedPairScore(Raw06(1.0, 1.0)),
            CalibratedPairScore(Raw06(1.0, 0.3)));
  // The silent score ignores the join (there is none to measure).
  PairFeatures silent = Silent(0.5);
  PairFeatures silent_poor = silent;
  silent_poor.agreement = 0.0;
  EXPECT_DOUBLE_EQ(CalibratedPairScore(silent),
                   CalibratedPairScore(silent_poor));
}

TEST(PairScore, SpeaksNeedsJudgementAndEnoughUniquePoints) {
  EXPECT_TRUE(Judged(kMinUniquePoints, 3, 3).Speaks());
  EXPECT_TRUE(Judged(100, 0, 0).Speaks());
  EXPECT_FALSE(Judged(kMinUniquePoints - 1, 3, 3).Speaks());
  PairFeatures not_judged = Judged(100, 50, 50);
  not_judged.judged = false;
  EXPECT_FALSE(not_judged.Speaks());
  EXPECT_FALSE(Silent(1.0).Speaks());
}

TEST(PairScore, SpeaksNeedsRepeatableDetection) {
  // Chance: 8 of 4 x 10 displaced predictions found, a rate of 0.2; the
  // models must find their own points at least kMinRepeatabilityOverChance
  // times as often.
  PairFeatures f = Judged(20, 10, 6);
  f.num_found_displaced = 8;
  const double chance = 8 / 40.0;
  f.models_checked = 1000;
  const int needed =
      static_cast<int>(kMinRepeatabilityOverChance * chance * 1000);
  f.models_found = needed + 5;
  EXPECT_TRUE(f.Speaks());
  f.models_found = needed - 5;
  EXPECT_FALSE(f.Speaks());
  // Not speaking, the raw score is the (capped) relative burstiness and
  // the silent table applies.
  f.relative_burstiness = 0.4;
  EXPECT_DOUBLE_EQ(f.RawScore(), 0.4);
  PairFeatures silent = Silent(0.4);
  EXPECT_DOUBLE_EQ(CalibratedPairScore(f), CalibratedPairScore(silent));
  // Models that checked nothing show no repeatability: silent unless
  // nothing was found by chance either.
  f.models_checked = 0;
  f.models_found = 0;
  EXPECT_FALSE(f.Speaks());
  f.num_found_displaced = 0;
  EXPECT_TRUE(f.Speaks());
}

TEST(PairScore, FromEvidenceCopiesTheCounts) {
  EdgeEvidence e;
  e.judged = true;
  e.num_unique = 12;
  e.num_visible = 9;
  e.num_found = 4;
  e.num_found_displaced = 3;
  e.models_checked = 50;
  e.models_found = 20;
  e.agreement_i = 0.9;
  e.agreement_j = 0.6;
  const PairFeatures f = PairFeatures::FromEvidence(e);
  EXPECT_TRUE(f.judged);
  EXPECT_EQ(f.num_unique, 12);
  EXPECT_EQ(f.num_visible, 9);
  EXPECT_EQ(f.num_found, 4);
  EXPECT_EQ(f.num_found_displaced, 3);
  EXPECT_EQ(f.models_checked, 50);
  EXPECT_EQ(f.models_found, 20);
  EXPECT_DOUBLE_EQ(f.agreement, 0.6);
  EXPECT_TRUE(f.Speaks());
  EXPECT_DOUBLE_EQ(f.RawScore(), 1.0 - 5.0 / 12.0);
}

TEST(PairScore, RawScoreFormula) {
  // Judged: one minus the missing share of the unique points.
  EXPECT_DOUBLE_EQ(Judged(20, 10, 10).RawScore(), 1.0);
  EXPECT_DOUBLE_EQ(Judged(20, 10, 5).RawScore(), 0.75);
  EXPECT_DOUBLE_EQ(Judged(20, 20, 0).RawScore(), 0.0);
  EXPECT_DOUBLE_EQ(Judged(8, 3, 1).RawScore(), 0.75);
  // More found than visible (inconsistent counts) is not better than none
  // missing.
  EXPECT_DOUBLE_EQ(Judged(10, 2, 5).RawScore(), 1.0);
  // Silent: the relative burstiness, capped.
  EXPECT_DOUBLE_EQ(Silent(0.3).RawScore(), 0.3);
  EXPECT_DOUBLE_EQ(Silent(1.0).RawScore(), kMaxSilentRawScore);
  EXPECT_DOUBLE_EQ(Silent(-0.5).RawScore(), 0.0);
  // Too few unique points: silent, whatever the counts say.
  PairFeatures few = Judged(kMinUniquePoints - 1, 4, 0);
  few.relative_burstiness = 0.6;
  EXPECT_DOUBLE_EQ(few.RawScore(), 0.6);
  // Raw scores stay in [0, 1].
  std::mt19937 rng(1);
  std::uniform_int_distribution<int> count(0, 40);
  std::uniform_real_distribution<double> u(-1, 2);
  for (int k = 0; k < 1000; ++k) {
    PairFeatures f = Judged(count(rng), count(rng), count(rng));
    f.judged = k % 3 != 0;
    f.relative_burstiness = u(rng);
    EXPECT_GE(f.RawScore(), 0.0);
    EXPECT_LE(f.RawScore(), 1.0);
  }
}

TEST(PairScore, SilentScoreInterpolatesBetweenBinCentres) {
  const auto& table = SilentCalibrationTable();
  auto score_at = [](double raw) { return CalibratedPairScore(Silent(raw)); };
  const int max_bin = 15;  // silent raw <= 0.75
  for (int k = 0; k < max_bin; ++k) {
    // At a bin centre: the table's value.
    EXPECT_NEAR(score_at((k + 0.5) / kScoreBins), table[k], 1e-9)
        << "bin " << k;
    // Half-way between two centres: the mean.
    if (k + 1 < max_bin) {
      EXPECT_NEAR(score_at((k + 1.0) / kScoreBins),
                  0.5 * (table[k] + table[k + 1]), 1e-9)
          << "bin " << k;
    }
  }
  // Below the first centre: the end value.
  EXPECT_NEAR(score_at(0.0), table[0], 1e-12);
  // A silent pair never scores above the table at the cap.
  const double at_cap = CalibratedPairScore(Silent(kMaxSilentRawScore));
  EXPECT_NEAR(CalibratedPairScore(Silent(1.0)), at_cap, 1e-12);
  EXPECT_LE(at_cap, table[kScoreBins - 1]);
}

TEST(PairScore, ScoresAreProbabilitiesMonotoneInTheRawScore) {
  for (const bool judged : {true, false}) {
    double previous = -1;
    for (int k = 0; k <= 1000; ++k) {
      const double raw = k / 1000.0;
      const double s = judged
                           ? CalibratedPairScore(Judged(1000, 1000 - k, 0))
                           : CalibratedPairScore(Silent(raw));
      EXPECT_GE(s, 0.0);
      EXPECT_LE(s, 1.0);
      EXPECT_GE(s, previous - 1e-15) << "raw " << raw;
      previous = s;
    }
  }
  // Fewer missing correspondences, same unique points: not a lower score.
  EXPECT_GT(CalibratedPairScore(Judged(40, 10, 10)),
            CalibratedPairScore(Judged(40, 30, 2)));
}

}  // namespace
}  // namespace hisfm
