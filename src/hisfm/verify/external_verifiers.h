// Plug-ins for users who have a learned two-view disambiguator (for example
// Doppelgangers++, Xiangli et al. 2025): precomputed scores from a file, or a
// command invoked on batches of bridge pairs only.
#pragma once

#include <map>
#include <string>
#include <utility>

#include "hisfm/graph/bridge_scorer.h"
#include "hisfm/verify/verifier_context.h"

namespace hisfm {

/// Scores read from a text file of lines `name1 name2 probability` (either
/// order of the names; '#' starts a comment). A bridge without a line is an
/// error, as is an unparsable line or a probability outside [0, 1].
class ScoresFileVerifier : public BridgeScorer {
 public:
  ScoresFileVerifier(const std::string& path, const VerifierContext& context);
  std::string Name() const override { return "scores:" + path_; }
  std::vector<double> Score(const std::vector<ImagePair>& pairs) override;
  size_t PreferredBatchSize() const override { return 64; }

 private:
  std::string path_;
  VerifierContext context_;
  std::map<std::pair<std::string, std::string>, double> scores_;
};

/// Runs `/bin/sh -c "CMD INPUT OUTPUT"` for each batch of at most
/// `batch_size` pairs (a longer list is cut into such batches): INPUT holds one line
/// `name1 name2` per bridge, and the command writes `name1 name2 probability`
/// lines to OUTPUT. The environment variable HISFM_IMAGE_PATH names the photo
/// folder. A failing command, a missing pair or an unparsable line is an
/// error.
class CommandVerifier : public BridgeScorer {
 public:
  CommandVerifier(std::string command, size_t batch_size,
                  const VerifierContext& context);
  std::string Name() const override { return "command:" + command_; }
  std::vector<double> Score(const std::vector<ImagePair>& pairs) override;
  size_t PreferredBatchSize() const override { return batch_size_; }

 private:
  // One call of the command on at most batch_size_ pairs.
  std::vector<double> ScoreBatch(const std::vector<ImagePair>& pairs);

  std::string command_;
  size_t batch_size_;
  VerifierContext context_;
};

/// Parses `name1 name2 probability` lines into a map keyed by the sorted
/// names; throws hisfm::Error naming `source` and the line on bad input.
std::map<std::pair<std::string, std::string>, double> ParseScoreLines(
    const std::string& text, const std::string& source);

}  // namespace hisfm
