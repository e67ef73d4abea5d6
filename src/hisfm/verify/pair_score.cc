#include "hisfm/verify/pair_score.h"

#include <algorithm>
#include <cmath>

namespace hisfm {

PairFeatures PairFeatures::FromEvidence(const EdgeEvidence& evidence) {
  PairFeatures f;
  f.judged = evidence.judged;
  f.num_unique = evidence.num_unique;
  f.num_visible = evidence.num_visible;
  f.num_found = evidence.num_found;
  f.agreement = std::min(evidence.agreement_i, evidence.agreement_j);
  return f;
}

std::array<double, 8> ScoreFeatureVector(const PairFeatures& f) {
  const bool speaks = f.judged && f.num_unique >= kMinUniquePoints;
  const double missing = std::max(0, f.num_visible - f.num_found);
  const double relb = std::clamp(f.relative_burstiness, 0.0, 1.0);
  return {1.0,
          speaks ? missing / f.num_unique : 0.0,
          speaks ? 1.0 : 0.0,
          speaks ? std::log1p(missing) : 0.0,
          relb,
          std::log(std::max(relb, 1e-3)),
          std::clamp(f.relative_inliers, 0.0, 1.0),
          f.judged ? f.agreement : 0.0};
}

const std::array<double, 8>& PairScoreCoefficients() {
  static const std::array<double, 8> kCoefficients = {
      -0.198, -0.975, 4.047, -1.258, 1.157, 0.3, 0.314, 1.498};
  return kCoefficients;
}

double CalibratedPairScore(const PairFeatures& features) {
  const std::array<double, 8> x = ScoreFeatureVector(features);
  const std::array<double, 8>& b = PairScoreCoefficients();
  double z = 0;
  for (size_t k = 0; k < x.size(); ++k) z += b[k] * x[k];
  return 1.0 / (1.0 + std::exp(-z));
}

}  // namespace hisfm
