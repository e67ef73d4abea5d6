#include "hisfm/util/interrupt.h"

#include <signal.h>
#include <string.h>
#include <sys/wait.h>

#include <atomic>
#include <cerrno>

namespace hisfm {
namespace {

constexpr int kSignals[] = {SIGINT, SIGTERM, SIGHUP};
constexpr int kNumSignals = sizeof(kSignals) / sizeof(kSignals[0]);

std::atomic<int> g_signal{0};
// The children a signal is forwarded to (0: a free slot): one for each run
// of colmap at a time (the sequence pass runs its chain's segments side by
// side).
constexpr int kMaxChildren = 64;
std::atomic<pid_t> g_children[kMaxChildren];
struct sigaction g_previous[kNumSignals];
bool g_caught[kNumSignals] = {};

extern "C" void OnInterrupt(int signal) {
  // Async-signal-safe only: atomics, kill, signal and raise.
  const int saved_errno = errno;
  int expected = 0;
  if (!g_signal.compare_exchange_strong(expected, signal)) {
    ::signal(signal, SIG_DFL);
    raise(signal);
  } else {
    for (std::atomic<pid_t>& slot : g_children) {
      if (const pid_t child = slot.load(); child != 0) kill(child, signal);
    }
  }
  errno = saved_errno;
}

}  // namespace

Interrupted::Interrupted(int signal)
    : Error(StrCat("interrupted by signal ", signal, " (", strsignal(signal),
                   ")")),
      signal_(signal) {}

InterruptScope::InterruptScope() {
  // A new scope starts clean: a signal of an earlier scope (a handled
  // KeyboardInterrupt in a Python session) does not stop this one.
  g_signal.store(0);
  for (std::atomic<pid_t>& slot : g_children) slot.store(0);
  struct sigaction action = {};
  action.sa_handler = OnInterrupt;
  action.sa_flags = SA_RESTART;
  sigemptyset(&action.sa_mask);
  for (int i = 0; i < kNumSignals; ++i) {
    sigaction(kSignals[i], nullptr, &g_previous[i]);
    // An ignored signal (nohup, background jobs of scripts) stays ignored.
    g_caught[i] = g_previous[i].sa_handler != SIG_IGN;
    if (g_caught[i]) sigaction(kSignals[i], &action, nullptr);
  }
}

InterruptScope::~InterruptScope() {
  for (int i = 0; i < kNumSignals; ++i) {
    if (g_caught[i]) sigaction(kSignals[i], &g_previous[i], nullptr);
  }
}

void ThrowIfInterrupted() {
  if (const int signal = g_signal.load(); signal != 0) {
    throw Interrupted(signal);
  }
}

void ThrowIfInterrupted(int wait_status) {
  ThrowIfInterrupted();
  if (WIFSIGNALED(wait_status)) {
    const int signal = WTERMSIG(wait_status);
    for (int s : kSignals) {
      if (s == signal) throw Interrupted(signal);
    }
  }
}

void AddInterruptibleChild(pid_t pid) {
  ThrowUnless(pid != 0, "AddInterruptibleChild: no process");
  bool added = false;
  for (std::atomic<pid_t>& slot : g_children) {
    pid_t free = 0;
    if (slot.compare_exchange_strong(free, pid)) {
      added = true;
      break;
    }
  }
  ThrowUnless(added, StrCat("more than ", kMaxChildren,
                            " interruptible children at once"));
  if (const int signal = g_signal.load(); signal != 0) kill(pid, signal);
}

void RemoveInterruptibleChild(pid_t pid) {
  for (std::atomic<pid_t>& slot : g_children) {
    pid_t expected = pid;
    if (slot.compare_exchange_strong(expected, 0)) return;
  }
}

size_t NumInterruptibleChildren() {
  size_t n = 0;
  for (const std::atomic<pid_t>& slot : g_children) n += slot.load() != 0;
  return n;
}

}  // namespace hisfm
