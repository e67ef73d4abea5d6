// Creation of the bridge verifier chosen by --HiSfM.verifier.
#pragma once

#include <memory>
#include <string>

#include "hisfm/graph/bridge_scorer.h"
#include "hisfm/verify/context_disambiguator.h"
#include "hisfm/verify/multiview_verifier.h"
#include "hisfm/verify/verified_hierarchy.h"
#include "hisfm/verify/pair_filter.h"
#include "hisfm/verify/verifier_context.h"

namespace hisfm {

struct VerifierOptions {
  /// Which verifier scores the bridges:
  ///   "builtin"       the multi-view disambiguator needing no learned
  ///                   weights (multiview_verifier.h; default);
  ///   "context"       the earlier two-view coverage and distinctive-track
  ///                   disambiguator (context_disambiguator.h) with the pair
  ///                   filter;
  ///   "none"          accept every bridge;
  ///   "scores:FILE"   precomputed `name1 name2 probability` lines;
  ///   "command:CMD"   run CMD on batches of bridges (see CommandVerifier).
  std::string verifier = "builtin";
  /// Pairs per call of a command verifier.
  int command_batch_size = 32;
  /// With a verifier other than "builtin", score the edges the paper
  /// trusts (community, intra-community and leaf edges) too and rebuild
  /// the hierarchy without the rejected ones (graph/trusted_edges.h, with
  /// verified_hierarchy.trusted_edges). The builtin verifier always does.
  bool judge_trusted_edges = true;
  /// With a plug-in verifier (IsPlugIn), reconstruct each edge used from
  /// the inliers that agree with the geometry the builtin edge test accepts
  /// for it (verified_hierarchy.h CleanInliers, within
  /// multiview.edge_test.inlier_error_factor), as the builtin verifier
  /// does: a true pair of a repeated facade also holds matches one
  /// repetition over, which a pair score cannot remove (decisions.md,
  /// 2026-12-03, sixth session).
  bool clean_plugin_inliers = true;
  /// Options of the builtin (multi-view) disambiguator.
  MultiViewVerifierOptions multiview;
  /// How the builtin verifier checks the trusted edges, adds support edges
  /// and cleans inliers; its trusted_edges options serve the other
  /// verifiers too (judge_trusted_edges), its support edges the plug-ins
  /// (IsPlugIn).
  VerifiedHierarchyOptions verified_hierarchy;
  /// With the builtin verifier, the hierarchy ranks pairs by burstiness-
  /// weighted support (match_burstiness.h) instead of inlier count:
  /// communities, leaves and the order in which Kruskal meets bridges.
  bool burstiness_weights = true;
  /// Options of the "context" disambiguator.
  DisambiguatorOptions builtin;
  /// Remove pairs explained by repeated structure from the view graph before
  /// the hierarchy is built (FilterAmbiguousPairs, pair_filter.h), so that
  /// neither communities, bridges nor leaves use them. Ignored with verifier
  /// "none", which stays the unverified baseline.
  bool filter_pairs = true;
  /// Options of that filter.
  PairFilterOptions pair_filter;

  void Check() const;
  /// filter_pairs and the "context" verifier.
  bool UsesPairFilter() const { return filter_pairs && verifier == "context"; }
  /// The verifier reads the communities (VerifierContext::communities), so
  /// it is created anew for every hierarchy built.
  bool UsesCommunities() const { return verifier == "context"; }
  /// The builtin multi-view verifier, which builds the hierarchy itself
  /// (verified_hierarchy.h).
  bool IsMultiView() const { return verifier == "builtin"; }
  /// A plug-in verifier (scores:FILE or command:CMD): it judges the pairs,
  /// and gets the support edges the builtin verifier adds to its own
  /// hierarchy (verified_hierarchy.support_edges, scored by the plug-in;
  /// cleaned inliers with clean_plugin_inliers).
  bool IsPlugIn() const;
};

/// Creates the verifier; throws hisfm::Error for an unknown kind or a bad
/// scores file.
std::unique_ptr<BridgeScorer> CreateVerifier(const VerifierOptions& options,
                                             const VerifierContext& context);

}  // namespace hisfm
