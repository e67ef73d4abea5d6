// Interruption (Ctrl-C, SIGTERM) that ends a run cleanly: the running colmap
// child is stopped with the same signal, and the run throws Interrupted at
// its next check, so that every temporary output is removed on the way out
// (file_util.h's AtomicDirectory) and no colmap process is left orphaned.
#pragma once

#include <sys/types.h>

#include "hisfm/util/error.h"

namespace hisfm {

/// Thrown by ThrowIfInterrupted; the `hisfm` command exits with 128 + signal.
class Interrupted : public Error {
 public:
  explicit Interrupted(int signal);
  int signal() const { return signal_; }

 private:
  int signal_;
};

/// Installs handlers for SIGINT, SIGTERM and SIGHUP. A first signal is
/// recorded and forwarded to the child registered with SetInterruptibleChild;
/// a second one ends the process at once (the default action).
void InstallInterruptHandlers();

/// The signal received since the handlers were installed, or 0.
int InterruptSignal();

/// Throws Interrupted if a signal was received.
void ThrowIfInterrupted();

/// Registers the child process that a signal is forwarded to (0: none).
/// If a signal arrived before the child was registered, it is forwarded at
/// once.
void SetInterruptibleChild(pid_t pid);

}  // namespace hisfm
