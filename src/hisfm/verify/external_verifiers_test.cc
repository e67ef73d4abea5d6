#include "hisfm/verify/external_verifiers.h"

#include <gtest/gtest.h>

#include <fstream>

#include "hisfm/util/error.h"
#include "hisfm/util/test_util.h"
#include "hisfm/verify/verifier_factory.h"

namespace hisfm {
namespace {

VerifierContext Names() {
  VerifierContext c;
  c.image_names = {{1, "a.jpg"}, {2, "b.jpg"}, {3, "c.jpg"}};
  c.image_path = "/photos";
  return c;
}

std::string ErrorOf(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

TEST(ScoresFileVerifier, ReadsScoresInEitherOrder) {
  TempDir tmp;
  std::ofstream(tmp / "s.txt") << "# doppelgangers++ output\n"
                               << "a.jpg b.jpg 0.9\n"
                               << "c.jpg a.jpg 0.05  # a doppelganger\n\n";
  ScoresFileVerifier v(tmp / "s.txt", Names());
  const std::vector<double> s =
      v.Score({ImagePair(1, 2), ImagePair(1, 3)});
  ASSERT_EQ(s.size(), 2u);
  EXPECT_DOUBLE_EQ(s[0], 0.9);
  EXPECT_DOUBLE_EQ(s[1], 0.05);
  const std::string missing = ErrorOf([&] { v.Score({ImagePair(2, 3)}); });
  EXPECT_NE(missing.find("no score for the pair b.jpg c.jpg"),
            std::string::npos)
      << missing;
}

TEST(ScoresFileVerifier, RejectsBadLines) {
  TempDir tmp;
  std::ofstream(tmp / "bad.txt") << "a.jpg b.jpg 0.9\na.jpg c.jpg high\n";
  std::string e = ErrorOf([&] { ScoresFileVerifier(tmp / "bad.txt", Names()); });
  EXPECT_NE(e.find("line 2"), std::string::npos) << e;
  std::ofstream(tmp / "range.txt") << "a.jpg b.jpg 1.5\n";
  e = ErrorOf([&] { ScoresFileVerifier(tmp / "range.txt", Names()); });
  EXPECT_NE(e.find("line 1"), std::string::npos) << e;
  std::ofstream(tmp / "short.txt") << "a.jpg b.jpg\n";
  e = ErrorOf([&] { ScoresFileVerifier(tmp / "short.txt", Names()); });
  EXPECT_NE(e.find("line 1"), std::string::npos) << e;
  e = ErrorOf([&] { ScoresFileVerifier(tmp / "none.txt", Names()); });
  EXPECT_NE(e.find("does not exist"), std::string::npos) << e;
}

TEST(CommandVerifier, RunsTheCommandOnBatches) {
  TempDir tmp;
  // A stand-in for a learned model: pairs with c.jpg are doppelgangers. It
  // also records each call and the photo folder it was given.
  std::ofstream(tmp / "scorer.sh")
      << "#!/bin/sh\n"
      << "echo \"$HISFM_IMAGE_PATH\" >> " << (tmp / "calls.txt") << "\n"
      << "awk '{ p = ($1 == \"c.jpg\" || $2 == \"c.jpg\") ? 0.1 : 0.8; "
         "print $1, $2, p }' \"$1\" > \"$2\"\n";
  VerifierOptions options;
  options.verifier = "command:sh " + (tmp / "scorer.sh");
  options.command_batch_size = 4;
  auto v = CreateVerifier(options, Names());
  EXPECT_EQ(v->PreferredBatchSize(), 4u);
  const std::vector<double> s =
      v->Score({ImagePair(1, 2), ImagePair(2, 3), ImagePair(1, 3)});
  EXPECT_EQ(s, (std::vector<double>{0.8, 0.1, 0.1}));
  v->Score({ImagePair(1, 2)});
  // Six pairs are cut into calls of at most four, scores kept in order.
  const std::vector<double> six =
      v->Score({ImagePair(1, 2), ImagePair(2, 3), ImagePair(1, 3),
                ImagePair(1, 2), ImagePair(1, 3), ImagePair(1, 2)});
  EXPECT_EQ(six, (std::vector<double>{0.8, 0.1, 0.1, 0.8, 0.1, 0.8}));
  std::ifstream calls(tmp / "calls.txt");
  std::string line;
  int n = 0;
  while (std::getline(calls, line)) {
    EXPECT_EQ(line, "/photos");
    ++n;
  }
  EXPECT_EQ(n, 4);
}

TEST(CommandVerifier, FailingOrSilentCommandIsAnError) {
  TempDir tmp;
  VerifierOptions options;
  options.verifier = "command:sh -c 'echo model crashed; exit 3' --";
  auto failing = CreateVerifier(options, Names());
  std::string e = ErrorOf([&] { failing->Score({ImagePair(1, 2)}); });
  EXPECT_NE(e.find("exit 3"), std::string::npos) << e;
  EXPECT_NE(e.find("model crashed"), std::string::npos) << e;
  options.verifier = "command:true";
  auto silent = CreateVerifier(options, Names());
  e = ErrorOf([&] { silent->Score({ImagePair(1, 2)}); });
  EXPECT_NE(e.find("wrote no scores"), std::string::npos) << e;
}

TEST(VerifierFactory, KnowsItsKinds) {
  VerifierOptions options;
  options.verifier = "none";
  EXPECT_EQ(CreateVerifier(options, Names())->Score({ImagePair(1, 2)}),
            std::vector<double>{1.0});
  options.verifier = "magic";
  EXPECT_THROW(options.Check(), Error);
  options.verifier = "scores:";
  EXPECT_THROW(options.Check(), Error);
}

}  // namespace
}  // namespace hisfm
