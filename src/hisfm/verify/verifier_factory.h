// Creation of the bridge verifier chosen by --HiSfM.verifier.
#pragma once

#include <memory>
#include <string>

#include "hisfm/graph/bridge_scorer.h"
#include "hisfm/verify/context_disambiguator.h"
#include "hisfm/verify/pair_filter.h"
#include "hisfm/verify/verifier_context.h"

namespace hisfm {

struct VerifierOptions {
  /// Which verifier scores the bridges:
  ///   "builtin"       the disambiguator needing no learned weights (default);
  ///   "none"          accept every bridge;
  ///   "scores:FILE"   precomputed `name1 name2 probability` lines;
  ///   "command:CMD"   run CMD on batches of bridges (see CommandVerifier).
  std::string verifier = "builtin";
  /// Pairs per call of a command verifier.
  int command_batch_size = 32;
  /// Options of the builtin disambiguator.
  DisambiguatorOptions builtin;
  /// Remove pairs explained by repeated structure from the view graph before
  /// the hierarchy is built (FilterAmbiguousPairs, pair_filter.h), so that
  /// neither communities, bridges nor leaves use them. Ignored with verifier
  /// "none", which stays the unverified baseline.
  bool filter_pairs = true;
  /// Options of that filter.
  PairFilterOptions pair_filter;

  void Check() const;
  /// filter_pairs and a verifier other than "none".
  bool UsesPairFilter() const { return filter_pairs && verifier != "none"; }
};

/// Creates the verifier; throws hisfm::Error for an unknown kind or a bad
/// scores file.
std::unique_ptr<BridgeScorer> CreateVerifier(const VerifierOptions& options,
                                             const VerifierContext& context);

}  // namespace hisfm
