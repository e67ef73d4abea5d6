// Child processes (colmap) that never outlive hisfm, however hisfm ends:
// Ctrl-C, SIGTERM, a crash or kill -9.
//
// The child runs in a process group of its own, with PR_SET_PDEATHSIG
// (SIGKILL when hisfm's thread that started it ends), and a small watchdog
// process waits on a pipe that only hisfm holds: when hisfm is gone the pipe
// closes and the watchdog kills the child's whole group, so that programs
// the child started (a wrapper script's colmap) die too. The watchdog
// ignores the terminal's signals and ends right after. When the child ends
// normally, the watchdog kills what is left of its group before the child
// is reaped (its group id cannot have been reused), then ends.
#pragma once

#include <string>
#include <vector>

namespace hisfm {

/// Runs `argv` (argv[0] looked up on PATH when it has no slash) with
/// standard input from /dev/null, standard output and error to `output_fd`,
/// and the environment `env` ("NAME=value" entries). Waits for it and
/// returns its exit code, 128 + the signal if a signal ended it, or -1 if it
/// could not start (the reason, an errno value, in *start_error). While it
/// runs, its process group is the child that hisfm/util/interrupt.h forwards
/// Ctrl-C and SIGTERM to. Call it from a thread that lives until it returns.
int RunChildProcess(const std::vector<std::string>& argv,
                    const std::vector<std::string>& env, int output_fd,
                    int* start_error);

/// This process's environment as "NAME=value" entries.
std::vector<std::string> CurrentEnvironment();

}  // namespace hisfm
