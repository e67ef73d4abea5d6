#include "hisfm/graph/bridge_scorer.h"

#include <unordered_set>

#include "hisfm/util/error.h"

namespace hisfm {

std::vector<double> MemoScorer::Score(const std::vector<ImagePair>& pairs) {
  std::vector<ImagePair> missing;
  std::unordered_set<ImagePair, ImagePairHash> asked;
  for (const ImagePair& p : pairs) {
    if (!scores_->count(p) && asked.insert(p).second) missing.push_back(p);
  }
  if (!missing.empty()) {
    const std::vector<double> s = Borrowed()->Score(missing);
    ThrowUnless(s.size() == missing.size(),
                StrCat("verifier '", Name(), "' returned ", s.size(),
                       " scores for ", missing.size(), " pairs"));
    for (size_t i = 0; i < missing.size(); ++i) {
      scores_->emplace(missing[i], s[i]);
    }
  }
  std::vector<double> out;
  out.reserve(pairs.size());
  for (const ImagePair& p : pairs) out.push_back(scores_->at(p));
  return out;
}

std::vector<double> PreVerifiedScorer::Forward(
    const std::vector<ImagePair>& pairs,
    const std::function<std::vector<double>(const std::vector<ImagePair>&)>&
        value) {
  std::vector<double> out(pairs.size(), 1.0);
  std::vector<ImagePair> asked;
  std::vector<size_t> where;
  for (size_t i = 0; i < pairs.size(); ++i) {
    if (accepted_->count(pairs[i])) {
      answered_->insert(pairs[i]);
    } else {
      asked.push_back(pairs[i]);
      where.push_back(i);
    }
  }
  if (asked.empty()) return out;
  const std::vector<double> values = value(asked);
  ThrowUnless(values.size() == asked.size(),
              StrCat("verifier '", Name(), "' returned ", values.size(),
                     " values for ", asked.size(), " pairs"));
  for (size_t k = 0; k < asked.size(); ++k) out[where[k]] = values[k];
  return out;
}

std::vector<double> PreVerifiedScorer::Score(
    const std::vector<ImagePair>& pairs) {
  return Forward(pairs, [this](const std::vector<ImagePair>& asked) {
    return Borrowed()->Score(asked);
  });
}

double PreVerifiedScorer::ConsistentShare(const ImagePair& pair) {
  return ConsistentShares({pair})[0];
}

std::vector<double> PreVerifiedScorer::ConsistentShares(
    const std::vector<ImagePair>& pairs) {
  return Forward(pairs, [this](const std::vector<ImagePair>& asked) {
    return Borrowed()->ConsistentShares(asked);
  });
}

size_t NumAskedOfScorer(const PairScores& scores,
                        const std::set<ImagePair>& accepted) {
  size_t n = 0;
  for (const auto& [pair, score] : scores) n += !accepted.count(pair);
  return n;
}

}  // namespace hisfm
