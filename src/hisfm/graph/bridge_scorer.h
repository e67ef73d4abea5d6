// The verification hook of the skeleton builder: scores inter-community
// bridges and, where the scorer can tell, weighs intra-community edges by
// their consistent inliers. The verify/ layer implements it
// (disambiguators, plug-ins).
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <set>
#include <string>
#include <unordered_map>
#include <vector>

#include "hisfm/util/types.h"

namespace hisfm {

/// Scores image pairs in [0, 1]: the probability that the pair sees the same
/// surface (not a doppelganger). Implementations may be expensive; the
/// skeleton builder calls them lazily and caches every score.
class BridgeScorer {
 public:
  virtual ~BridgeScorer() = default;
  /// Short name for logs and summaries.
  virtual std::string Name() const = 0;
  /// Scores a batch of pairs; returns one score per pair, in order.
  virtual std::vector<double> Score(const std::vector<ImagePair>& pairs) = 0;
  /// How many pairs the scorer prefers per call (1 = strictly lazy).
  virtual size_t PreferredBatchSize() const { return 1; }
  /// True if a score costs nothing (no test is run): verification budgets
  /// (SkeletonOptions::redundant_budget_trees) do not apply.
  virtual bool IsFree() const { return false; }
  /// The rotation error (degrees) around the closed walk `cycle` = (v0, v1,
  /// ..., vn, back to v0), each consecutive pair an edge of the view graph:
  /// the angle of the composition of the pairs' relative rotations, which is
  /// zero for a loop of true pairs (Zach, Klopschitz, Pollefeys, CVPR 2010).
  /// Negative if the scorer cannot tell (the default).
  virtual double CycleRotationErrorDeg(const std::vector<ImageId>& cycle) {
    (void)cycle;
    return -1.0;
  }
  /// The share, in [0, 1], of the pair's inliers that agree with the
  /// relative pose the scorer accepts for it; 1 if the scorer cannot tell
  /// (the default). May be as costly as a score.
  virtual double ConsistentShare(const ImagePair& pair) {
    (void)pair;
    return 1.0;
  }
  /// ConsistentShare of each pair, in order. The default asks them one at a
  /// time; a scorer that can judge pairs in parallel overrides it.
  virtual std::vector<double> ConsistentShares(
      const std::vector<ImagePair>& pairs) {
    std::vector<double> shares;
    shares.reserve(pairs.size());
    for (const ImagePair& pair : pairs) shares.push_back(ConsistentShare(pair));
    return shares;
  }
};

/// A non-owning adapter: forwards every call to a scorer the caller keeps
/// alive (for APIs that take ownership of a scorer, e.g. ScorerFactory).
class BorrowedScorer : public BridgeScorer {
 public:
  /// `scorer` must be non-null and outlive this object.
  explicit BorrowedScorer(BridgeScorer* scorer) : scorer_(scorer) {}
  std::string Name() const override { return scorer_->Name(); }
  std::vector<double> Score(const std::vector<ImagePair>& pairs) override {
    return scorer_->Score(pairs);
  }
  size_t PreferredBatchSize() const override {
    return scorer_->PreferredBatchSize();
  }
  bool IsFree() const override { return scorer_->IsFree(); }
  double CycleRotationErrorDeg(const std::vector<ImageId>& cycle) override {
    return scorer_->CycleRotationErrorDeg(cycle);
  }
  double ConsistentShare(const ImagePair& pair) override {
    return scorer_->ConsistentShare(pair);
  }
  std::vector<double> ConsistentShares(
      const std::vector<ImagePair>& pairs) override {
    return scorer_->ConsistentShares(pairs);
  }

 protected:
  /// The scorer every call is forwarded to.
  BridgeScorer* Borrowed() const { return scorer_; }

 private:
  BridgeScorer* scorer_;
};

/// Scores already known, by pair.
using PairScores = std::unordered_map<ImagePair, double, ImagePairHash>;

/// Forwards to a scorer and remembers every score in a map the caller owns,
/// so that no pair is asked of the scorer twice while the map lives (across
/// rebuilds of the hierarchy and the stages after it); a pair repeated
/// within one batch is asked once too. Throws hisfm::Error if the scorer
/// returns the wrong number of scores.
class MemoScorer : public BorrowedScorer {
 public:
  /// `scorer` is shared and must be non-null; `scores` must be non-null and
  /// outlive this object.
  MemoScorer(std::shared_ptr<BridgeScorer> scorer, PairScores* scores)
      : BorrowedScorer(scorer.get()),
        owner_(std::move(scorer)),
        scores_(scores) {}
  std::vector<double> Score(const std::vector<ImagePair>& pairs) override;

 private:
  std::shared_ptr<BridgeScorer> owner_;
  PairScores* scores_;
};

/// Forwards to a scorer, except for the pairs another test has already
/// accepted (the sequence pass's transfer test against a multi-view model,
/// recon/sequence_pass.h): those score 1 and keep every inlier
/// (ConsistentShare 1) without a call to the scorer. The pairs answered so
/// far are added to a set the caller owns, so that several of these scorers
/// (one per build of the hierarchy) count them once.
class PreVerifiedScorer : public BorrowedScorer {
 public:
  /// `scorer` is shared and must be non-null; `accepted` and `answered`
  /// must be non-null and outlive this object.
  PreVerifiedScorer(std::shared_ptr<BridgeScorer> scorer,
                    const std::set<ImagePair>* accepted,
                    std::set<ImagePair>* answered)
      : BorrowedScorer(scorer.get()),
        owner_(std::move(scorer)),
        accepted_(accepted),
        answered_(answered) {}
  std::vector<double> Score(const std::vector<ImagePair>& pairs) override;
  double ConsistentShare(const ImagePair& pair) override;
  std::vector<double> ConsistentShares(
      const std::vector<ImagePair>& pairs) override;

 private:
  // The scorer's values for `pairs`, 1 for the accepted ones (asked of
  // `value` in one batch, the others only).
  std::vector<double> Forward(
      const std::vector<ImagePair>& pairs,
      const std::function<std::vector<double>(const std::vector<ImagePair>&)>&
          value);

  std::shared_ptr<BridgeScorer> owner_;
  const std::set<ImagePair>* accepted_;
  std::set<ImagePair>* answered_;
};

/// How many pairs of `scores` (a MemoScorer's, over a PreVerifiedScorer with
/// `accepted`) the scorer behind them was asked about: those not accepted,
/// which the PreVerifiedScorer answers itself.
size_t NumAskedOfScorer(const PairScores& scores,
                        const std::set<ImagePair>& accepted);

/// The default of the foundation: accepts every bridge with score 1.
class AcceptAllScorer : public BridgeScorer {
 public:
  std::string Name() const override { return "none"; }
  bool IsFree() const override { return true; }
  std::vector<double> Score(const std::vector<ImagePair>& pairs) override {
    return std::vector<double>(pairs.size(), 1.0);
  }
};

}  // namespace hisfm
