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

}  // namespace hisfm
