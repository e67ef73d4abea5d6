#include "hisfm/verify/pair_score.h"

#include <algorithm>
#include <cmath>

namespace hisfm {
namespace {

// P(true | raw score) in 20 bins of width 0.05 (pair_score.h), for pairs
// the edge test judged and for pairs it could not.
constexpr std::array<double, kScoreBins> kJudged = {
    0.192, 0.192, 0.192, 0.192, 0.192, 0.301, 0.338, 0.475, 0.608, 0.608,
    0.621, 0.621, 0.621, 0.621, 0.676, 0.718, 0.718, 0.718, 0.837, 0.946};
constexpr std::array<double, kScoreBins> kSilent = {
    0.203, 0.519, 0.519, 0.519, 0.752, 0.830, 0.830, 0.852, 0.852, 0.852,
    0.957, 0.957, 0.972, 0.972, 0.985, 0.999, 0.999, 0.999, 0.999, 0.999};

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
  const std::array<double, kScoreBins>& table =
      features.Speaks() ? kJudged : kSilent;
  // Linear interpolation between bin centres.
  const double x = features.RawScore() * kScoreBins - 0.5;
  const int lo = std::clamp(static_cast<int>(std::floor(x)), 0, kScoreBins - 1);
  const int hi = std::min(lo + 1, kScoreBins - 1);
  const double f = std::clamp(x - lo, 0.0, 1.0);
  return (1 - f) * table[lo] + f * table[hi];
}

const std::array<double, kScoreBins>& CalibrationTable(bool judged) {
  return judged ? kJudged : kSilent;
}

}  // namespace hisfm
