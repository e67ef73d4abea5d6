#include "hisfm/verify/pair_score.h"

#include <algorithm>
#include <cmath>

namespace hisfm {
namespace {

// The fit of scripts/fit_score_calibration.py on the tuning half
// (pair_score.h; docs/decisions.md, 2026-12-02).
constexpr JudgedScoreModel kJudgedModel = {-5.582, 5.334, 1.897, 2.927};
// P(true | raw score) in 20 bins of width 0.05, for pairs the edge test
// could not judge.
constexpr std::array<double, kScoreBins> kSilent = {
    0.300, 0.674, 0.674, 0.674, 0.740, 0.850, 0.850, 0.854, 0.854, 0.854,
    0.974, 0.989, 0.989, 0.989, 0.991, 0.999, 0.999, 0.999, 0.999, 0.999};

// The table's value at a raw score (linear between bin centres).
double Interpolate(const std::array<double, kScoreBins>& table, double raw) {
  const double x = raw * kScoreBins - 0.5;
  const int lo = std::clamp(static_cast<int>(std::floor(x)), 0, kScoreBins - 1);
  const int hi = std::min(lo + 1, kScoreBins - 1);
  const double f = std::clamp(x - lo, 0.0, 1.0);
  return (1 - f) * table[lo] + f * table[hi];
}

}  // namespace

PairFeatures PairFeatures::FromEvidence(const EdgeEvidence& evidence) {
  PairFeatures f;
  f.judged = evidence.judged;
  f.num_unique = evidence.num_unique;
  f.num_visible = evidence.num_visible;
  f.num_found = evidence.num_found;
  f.num_found_displaced = evidence.num_found_displaced;
  f.models_checked = evidence.models_checked;
  f.models_found = evidence.models_found;
  f.agreement = std::min(evidence.agreement_i, evidence.agreement_j);
  return f;
}

bool PairFeatures::Speaks() const {
  if (!judged || num_unique < kMinUniquePoints) return false;
  const double chance =
      num_visible > 0 ? num_found_displaced / (4.0 * num_visible) : 0.0;
  const double repeatability =
      models_checked > 0 ? static_cast<double>(models_found) / models_checked
                         : 0.0;
  return repeatability >= kMinRepeatabilityOverChance * chance;
}

double PairFeatures::RawScore() const {
  if (Speaks()) {
    const double missing = std::max(0, num_visible - num_found);
    return std::clamp(1.0 - missing / num_unique, 0.0, 1.0);
  }
  return std::clamp(relative_burstiness, 0.0, kMaxSilentRawScore);
}

double CalibratedPairScore(const PairFeatures& features) {
  if (features.Speaks()) {
    const JudgedScoreModel& m = kJudgedModel;
    const double z = m.intercept + m.raw * features.RawScore() +
                     m.agreement * std::clamp(features.agreement, 0.0, 1.0) +
                     m.relative_burstiness *
                         std::clamp(features.relative_burstiness, 0.0, 1.0);
    return 1.0 / (1.0 + std::exp(-z));
  }
  return Interpolate(kSilent, features.RawScore());
}

const JudgedScoreModel& JudgedModel() { return kJudgedModel; }

const std::array<double, kScoreBins>& SilentCalibrationTable() {
  return kSilent;
}

}  // namespace hisfm
