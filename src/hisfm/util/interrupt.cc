#include "hisfm/util/interrupt.h"

#include <signal.h>
#include <string.h>

#include <atomic>

namespace hisfm {
namespace {

std::atomic<int> g_signal{0};
std::atomic<pid_t> g_child{0};

extern "C" void OnInterrupt(int signal) {
  // Async-signal-safe only: atomics, kill and signal.
  int expected = 0;
  if (!g_signal.compare_exchange_strong(expected, signal)) {
    ::signal(signal, SIG_DFL);
    raise(signal);
    return;
  }
  const pid_t child = g_child.load();
  if (child > 0) kill(child, signal);
}

}  // namespace

Interrupted::Interrupted(int signal)
    : Error(StrCat("interrupted by signal ", signal, " (", strsignal(signal),
                   ")")),
      signal_(signal) {}

void InstallInterruptHandlers() {
  struct sigaction action = {};
  action.sa_handler = OnInterrupt;
  sigemptyset(&action.sa_mask);
  for (int signal : {SIGINT, SIGTERM, SIGHUP}) {
    sigaction(signal, &action, nullptr);
  }
}

int InterruptSignal() { return g_signal.load(); }

void ThrowIfInterrupted() {
  if (const int signal = g_signal.load(); signal != 0) {
    throw Interrupted(signal);
  }
}

void SetInterruptibleChild(pid_t pid) {
  g_child.store(pid);
  const int signal = g_signal.load();
  if (pid > 0 && signal != 0) kill(pid, signal);
}

}  // namespace hisfm
