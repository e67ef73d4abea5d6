// Runs the `colmap` command-line back-end (COLMAP 3.8 to 4.1, see
// hisfm/io/colmap_version.h) as a child process.
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
/// run and is a COLMAP release hisfm knows (else the error names its
/// version); returns its version line ("COLMAP 3.8 ...").
std::string CheckColmapAvailable(const ColmapRunnerOptions& options);

/// Runs `colmap <args...>` with stdout and stderr appended to `log_path`.
/// `args` use COLMAP 3.8's option names; they are given the names of the
/// colmap that runs (TranslateColmapArguments), whose version is read once.
/// Throws hisfm::Error naming the command and quoting the end of the log if
/// it cannot start or exits non-zero. Returns the wall time in seconds.
double RunColmap(const ColmapRunnerOptions& options,
                 const std::vector<std::string>& args,
                 const std::string& log_path);

}  // namespace hisfm
