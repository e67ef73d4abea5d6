// Interruption (Ctrl-C, SIGTERM, SIGHUP) that ends a run cleanly: inside an
// InterruptScope the running colmap child is stopped with the same signal,
// and the run throws Interrupted at its next check, so that every temporary
// output is removed on the way out (file_util.h's AtomicDirectory) and no
// colmap process is left orphaned. Outside a scope signals keep their
// default action.
#pragma once

#include <sys/types.h>

#include <cstddef>

#include "hisfm/util/error.h"

namespace hisfm {

/// Thrown by ThrowIfInterrupted. The `hisfm` command prints it and then ends
/// by the same signal (so that a calling shell script stops too).
class Interrupted : public Error {
 public:
  explicit Interrupted(int signal);
  int signal() const { return signal_; }

 private:
  int signal_;
};

/// While one lives, SIGINT, SIGTERM and SIGHUP are caught (unless they were
/// ignored, as under nohup): a first signal is recorded and forwarded to the
/// child registered with SetInterruptibleChild; a second one ends the
/// process at once. The previous handlers come back on destruction, and a
/// signal recorded but not thrown is forgotten then: a command calls
/// ThrowIfInterrupted between its stages and once more at the end of the
/// scope, so that a Ctrl-C during its last step still stops it. A new scope
/// starts with no signal recorded. One at a time per process.
class InterruptScope {
 public:
  InterruptScope();
  ~InterruptScope();
  InterruptScope(const InterruptScope&) = delete;
  InterruptScope& operator=(const InterruptScope&) = delete;
};

/// Throws Interrupted if a signal was received.
void ThrowIfInterrupted();

/// Same, and also if `wait_status` (of waitpid or std::system) tells that
/// the child died of SIGINT, SIGTERM or SIGHUP: a Ctrl-C that reached the
/// child while std::system ignored it here.
void ThrowIfInterrupted(int wait_status);

/// Registers a child process that a signal is forwarded to (a negative
/// value -pgid names a process group, as for kill); several may be
/// registered at once, from several threads (up to 64). If a signal arrived
/// before the child was registered, it is forwarded at once. Throws
/// hisfm::Error for pid 0 or when every slot is taken.
void AddInterruptibleChild(pid_t pid);

/// Unregisters a child of AddInterruptibleChild (nothing if it is not
/// registered).
void RemoveInterruptibleChild(pid_t pid);

/// How many children are registered.
size_t NumInterruptibleChildren();

}  // namespace hisfm
