#include "hisfm/util/interrupt.h"

#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <csignal>
#include <vector>

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

// Several children at once (the chain's segments run side by side): each
// gets the signal, and each is forgotten once it is removed.
TEST(InterruptScope, EveryRegisteredChildGetsTheSignal) {
  InterruptScope scope;
  // The children die of the signal by its default action: blocked until
  // they have restored it.
  sigset_t term;
  sigemptyset(&term);
  sigaddset(&term, SIGTERM);
  sigset_t before;
  ASSERT_EQ(sigprocmask(SIG_BLOCK, &term, &before), 0);
  std::vector<pid_t> children;
  for (int i = 0; i < 2; ++i) {
    const pid_t pid = fork();
    ASSERT_GE(pid, 0);
    if (pid == 0) {
      signal(SIGTERM, SIG_DFL);
      sigprocmask(SIG_UNBLOCK, &term, nullptr);
      for (;;) pause();
    }
    children.push_back(pid);
    AddInterruptibleChild(pid);
  }
  ASSERT_EQ(sigprocmask(SIG_SETMASK, &before, nullptr), 0);
  EXPECT_EQ(NumInterruptibleChildren(), 2u);
  ASSERT_EQ(std::raise(SIGTERM), 0);
  for (const pid_t pid : children) {
    int status = 0;
    ASSERT_EQ(waitpid(pid, &status, 0), pid);
    EXPECT_TRUE(WIFSIGNALED(status));
    EXPECT_EQ(WTERMSIG(status), SIGTERM);
    RemoveInterruptibleChild(pid);
  }
  EXPECT_EQ(NumInterruptibleChildren(), 0u);
  EXPECT_THROW(ThrowIfInterrupted(), Interrupted);
  EXPECT_THROW(AddInterruptibleChild(0), Error);
}

}  // namespace
}  // namespace hisfm
