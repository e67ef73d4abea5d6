#include "hisfm/util/error.h"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace hisfm {
namespace {

struct ExampleOptions {
  int top_k = 1;
  double ratio = 0.5;
  bool enabled = true;
  std::string name = "x";
  std::vector<double> thresholds = {1, 2};

  void Check() const {
    HISFM_CHECK_OPTION(top_k, top_k >= 1, ">= 1");
    HISFM_CHECK_OPTION(ratio, ratio >= 0 && ratio <= 1, "in [0, 1]");
    HISFM_CHECK_OPTION(enabled, enabled, "true");
    HISFM_CHECK_OPTION(name, !name.empty(), "non-empty");
    HISFM_CHECK_OPTION(thresholds, thresholds.size() == 2, "two values");
  }
};

// The message of the first failing check of `o`, "" if none fails.
std::string FirstFailure(const ExampleOptions& o, const void** field) {
  try {
    o.Check();
  } catch (const OptionError& e) {
    *field = e.field();
    return e.what();
  }
  return "";
}

TEST(OptionError, NamesTheOptionItsValueAndTheRequirement) {
  ExampleOptions o;
  const void* field = nullptr;
  EXPECT_EQ(FirstFailure(o, &field), "");
  o.top_k = 0;
  EXPECT_EQ(FirstFailure(o, &field), "invalid option top_k = 0: must be >= 1");
  EXPECT_EQ(field, &o.top_k);
  o = ExampleOptions();
  o.ratio = 1.25;
  EXPECT_EQ(FirstFailure(o, &field),
            "invalid option ratio = 1.25: must be in [0, 1]");
  EXPECT_EQ(field, &o.ratio);
  o = ExampleOptions();
  o.enabled = false;
  EXPECT_EQ(FirstFailure(o, &field),
            "invalid option enabled = false: must be true");
  o = ExampleOptions();
  o.name = "";
  EXPECT_EQ(FirstFailure(o, &field),
            "invalid option name = \"\": must be non-empty");
  o = ExampleOptions();
  o.thresholds = {0.5, 1, 2};
  EXPECT_EQ(FirstFailure(o, &field),
            "invalid option thresholds = [0.5, 1, 2]: must be two values");
  EXPECT_EQ(field, &o.thresholds);
}

TEST(OptionError, WithNameKeepsTheRest) {
  int top_k = 0;
  const OptionError e(&top_k, "top_k", "0", ">= 1");
  const OptionError flagged = e.WithName("--HiSfM.top_k");
  EXPECT_STREQ(flagged.what(),
               "invalid option --HiSfM.top_k = 0: must be >= 1");
  EXPECT_EQ(flagged.field(), &top_k);
  EXPECT_EQ(flagged.value(), "0");
  EXPECT_EQ(flagged.requirement(), ">= 1");
  EXPECT_EQ(flagged.name(), "--HiSfM.top_k");
  // An OptionError is a hisfm::Error: the command prints it in one line.
  EXPECT_THROW(throw flagged, Error);
}

}  // namespace
}  // namespace hisfm
