#include "hisfm/verify/verifier_factory.h"

#include "hisfm/util/error.h"
#include "hisfm/verify/external_verifiers.h"

namespace hisfm {
namespace {

bool StartsWith(const std::string& s, const std::string& prefix) {
  return s.compare(0, prefix.size(), prefix) == 0;
}

}  // namespace

void VerifierOptions::Check() const {
  HISFM_CHECK_OPTION(command_batch_size, command_batch_size >= 1, ">= 1");
  builtin.Check();
  multiview.Check();
  verified_hierarchy.Check();
  pair_filter.Check();
  ThrowUnless(verifier == "builtin" || verifier == "context" ||
                  verifier == "none" ||
                  (StartsWith(verifier, "scores:") && verifier.size() > 7) ||
                  (StartsWith(verifier, "command:") && verifier.size() > 8),
              StrCat("invalid --HiSfM.verifier '", verifier,
                     "': use builtin, none, scores:FILE or command:CMD"));
}

bool VerifierOptions::IsPlugIn() const {
  return StartsWith(verifier, "scores:") || StartsWith(verifier, "command:");
}

std::unique_ptr<BridgeScorer> CreateVerifier(const VerifierOptions& options,
                                             const VerifierContext& context) {
  options.Check();
  const std::string& v = options.verifier;
  if (v == "none") return std::make_unique<AcceptAllScorer>();
  if (StartsWith(v, "scores:")) {
    return std::make_unique<ScoresFileVerifier>(v.substr(7), context);
  }
  if (StartsWith(v, "command:")) {
    return std::make_unique<CommandVerifier>(v.substr(8),
                                             options.command_batch_size,
                                             context);
  }
  if (v == "context") {
    return std::make_unique<ContextDisambiguator>(context, options.builtin);
  }
  ThrowUnless(context.database && context.graph,
              "the builtin verifier needs the database and the view graph");
  return std::make_unique<MultiViewVerifier>(*context.database,
                                             *context.graph,
                                             options.multiview);
}

}  // namespace hisfm
