// Runs the `colmap` command-line back-end (COLMAP 3.8) as a child process.
#pragma once

#include <string>
#include <vector>

namespace hisfm {

struct ColmapRunnerOptions {
  /// The colmap executable (searched on PATH when it has no slash).
  std::string colmap_path = "colmap";

  void Check() const;
};

/// Throws hisfm::Error("colmap not found ...") unless the executable can be
/// run; returns its version line ("COLMAP 3.8 ...").
std::string CheckColmapAvailable(const ColmapRunnerOptions& options);

/// Runs `colmap <args...>` with stdout and stderr appended to `log_path`.
/// Throws hisfm::Error naming the command and quoting the end of the log if
/// it cannot start or exits non-zero. Returns the wall time in seconds.
double RunColmap(const ColmapRunnerOptions& options,
                 const std::vector<std::string>& args,
                 const std::string& log_path);

}  // namespace hisfm
