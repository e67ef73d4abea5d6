#include "hisfm/util/interrupt.h"

#include <gtest/gtest.h>

#include <csignal>

namespace hisfm {
namespace {

TEST(InterruptScope, ASignalInsideTheScopeIsThrownAtTheNextCheck) {
  InterruptScope scope;
  EXPECT_NO_THROW(ThrowIfInterrupted());
  ASSERT_EQ(std::raise(SIGINT), 0);  // Recorded, not fatal, inside a scope.
  try {
    ThrowIfInterrupted();
    FAIL() << "no Interrupted thrown";
  } catch (const Interrupted& e) {
    EXPECT_EQ(e.signal(), SIGINT);
  }
  // It stays recorded until the scope ends: every later check throws.
  EXPECT_THROW(ThrowIfInterrupted(), Interrupted);
}

TEST(InterruptScope, ANewScopeForgetsTheSignalOfAnEarlierOne) {
  {
    InterruptScope first;
    ASSERT_EQ(std::raise(SIGTERM), 0);
    EXPECT_THROW(ThrowIfInterrupted(), Interrupted);
  }
  // A second call of the Python module after a handled KeyboardInterrupt.
  InterruptScope second;
  EXPECT_NO_THROW(ThrowIfInterrupted());
  EXPECT_NO_THROW(ThrowIfInterrupted(0));
}

}  // namespace
}  // namespace hisfm
