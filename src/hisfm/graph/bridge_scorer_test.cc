#include "hisfm/graph/bridge_scorer.h"

#include <gtest/gtest.h>

#include <map>
#include <memory>
#include <set>

#include "hisfm/util/error.h"

namespace hisfm {
namespace {

// Scores a pair by its first image's id over 100; counts the calls per pair.
// With `drop_last`, returns one score too few.
struct CountingScorer : BridgeScorer {
  std::map<ImagePair, int> calls;
  bool drop_last = false;
  std::string Name() const override { return "counting"; }
  std::vector<double> Score(const std::vector<ImagePair>& pairs) override {
    std::vector<double> s;
    for (const ImagePair& p : pairs) {
      ++calls[p];
      s.push_back(p.image_id1 / 100.0);
    }
    if (drop_last && !s.empty()) s.pop_back();
    return s;
  }
  double ConsistentShare(const ImagePair& pair) override {
    return pair.image_id2 / 100.0;
  }
};

// Reports other shares in batches than one by one, to tell which path an
// adapter took.
struct BatchCountingScorer : CountingScorer {
  std::vector<double> ConsistentShares(
      const std::vector<ImagePair>& pairs) override {
    std::vector<double> shares;
    for (const ImagePair& p : pairs) shares.push_back(p.image_id1 / 100.0);
    return shares;
  }
};

TEST(BridgeScorer, ConsistentSharesAreForwardedByTheAdapters) {
  auto counting = std::make_shared<CountingScorer>();
  BorrowedScorer borrowed(counting.get());
  EXPECT_DOUBLE_EQ(borrowed.ConsistentShare(ImagePair(1, 40)), 0.4);
  PairScores scores;
  MemoScorer memo(counting, &scores);
  EXPECT_DOUBLE_EQ(memo.ConsistentShare(ImagePair(2, 70)), 0.7);
  // A scorer that cannot tell reports a full share.
  AcceptAllScorer none;
  EXPECT_DOUBLE_EQ(none.ConsistentShare(ImagePair(2, 70)), 1.0);
  // Batches: by default one pair at a time, in order.
  EXPECT_EQ(counting->ConsistentShares({ImagePair(1, 40), ImagePair(2, 70)}),
            (std::vector<double>{0.4, 0.7}));
  EXPECT_EQ(none.ConsistentShares({ImagePair(1, 2), ImagePair(3, 4)}),
            (std::vector<double>{1.0, 1.0}));
  // The adapters forward batches to the scorer's own batch path.
  auto batching = std::make_shared<BatchCountingScorer>();
  BorrowedScorer borrowed_batch(batching.get());
  EXPECT_EQ(borrowed_batch.ConsistentShares({ImagePair(3, 90)}),
            (std::vector<double>{0.03}));
  MemoScorer memo_batch(batching, &scores);
  EXPECT_EQ(memo_batch.ConsistentShares({ImagePair(5, 90), ImagePair(6, 7)}),
            (std::vector<double>{0.05, 0.06}));
}

TEST(PreVerifiedScorer, AnswersAcceptedPairsWithoutAskingTheScorer) {
  auto counting = std::make_shared<BatchCountingScorer>();
  const std::set<ImagePair> accepted = {ImagePair(2, 3), ImagePair(7, 8)};
  std::set<ImagePair> answered;
  PreVerifiedScorer scorer(counting, &accepted, &answered);
  // Accepted pairs score 1 in their place; the others are the scorer's, in
  // one batch.
  EXPECT_EQ(scorer.Score({ImagePair(1, 2), ImagePair(2, 3), ImagePair(5, 6)}),
            (std::vector<double>{0.01, 1.0, 0.05}));
  EXPECT_EQ(counting->calls.count(ImagePair(2, 3)), 0u);
  EXPECT_EQ(counting->calls[ImagePair(1, 2)], 1);
  // A batch of accepted pairs only asks nothing.
  EXPECT_EQ(scorer.Score({ImagePair(7, 8)}), (std::vector<double>{1.0}));
  EXPECT_EQ(counting->calls.size(), 2u);
  // Accepted pairs keep every inlier; the others' shares are the scorer's,
  // through its batch path.
  EXPECT_DOUBLE_EQ(scorer.ConsistentShare(ImagePair(2, 3)), 1.0);
  EXPECT_EQ(scorer.ConsistentShares({ImagePair(4, 9), ImagePair(7, 8)}),
            (std::vector<double>{0.04, 1.0}));
  // A second scorer over the same sets counts each answered pair once.
  PreVerifiedScorer again(counting, &accepted, &answered);
  again.Score({ImagePair(2, 3)});
  EXPECT_EQ(answered, accepted);
  // A scorer that returns too few scores is an error.
  counting->drop_last = true;
  EXPECT_THROW(scorer.Score({ImagePair(1, 2), ImagePair(5, 6)}), Error);
}

TEST(NumAskedOfScorer, CountsThePairsTheScorerBehindWasAsked) {
  auto counting = std::make_shared<BatchCountingScorer>();
  const std::set<ImagePair> accepted = {ImagePair(2, 3), ImagePair(7, 8)};
  std::set<ImagePair> answered;
  PairScores scores;
  MemoScorer memo(
      std::make_shared<PreVerifiedScorer>(counting, &accepted, &answered),
      &scores);
  memo.Score({ImagePair(1, 2), ImagePair(2, 3), ImagePair(5, 6)});
  memo.Score({ImagePair(7, 8), ImagePair(1, 2), ImagePair(4, 9)});
  EXPECT_EQ(scores.size(), 5u);
  EXPECT_EQ(counting->calls.size(), 3u);
  EXPECT_EQ(NumAskedOfScorer(scores, accepted), counting->calls.size());
  EXPECT_EQ(NumAskedOfScorer(scores, {}), scores.size());
}

TEST(MemoScorer, AsksEachPairOnceWhileTheScoresLive) {
  auto counting = std::make_shared<CountingScorer>();
  PairScores scores;
  MemoScorer first(counting, &scores);
  EXPECT_EQ(first.Score({ImagePair(1, 2), ImagePair(3, 4)}),
            (std::vector<double>{0.01, 0.03}));
  // A second memo over the same scores (a later stage) asks only the new
  // pair, and returns the scores in the order asked.
  MemoScorer second(counting, &scores);
  EXPECT_EQ(second.Score({ImagePair(5, 6), ImagePair(3, 4), ImagePair(1, 2)}),
            (std::vector<double>{0.05, 0.03, 0.01}));
  EXPECT_EQ(scores.size(), 3u);
  for (const auto& [pair, n] : counting->calls) {
    EXPECT_EQ(n, 1) << pair.image_id1 << "-" << pair.image_id2;
  }
  EXPECT_EQ(second.Name(), "counting");

  // A pair repeated within one batch is asked once and answered twice.
  EXPECT_EQ(second.Score({ImagePair(9, 10), ImagePair(9, 10)}),
            (std::vector<double>{0.09, 0.09}));
  EXPECT_EQ(counting->calls.at(ImagePair(9, 10)), 1);

  counting->drop_last = true;
  EXPECT_THROW(second.Score({ImagePair(7, 8)}), Error);
  EXPECT_EQ(scores.count(ImagePair(7, 8)), 0u);
}

}  // namespace
}  // namespace hisfm
