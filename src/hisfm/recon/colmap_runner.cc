#include "hisfm/recon/colmap_runner.h"

#include <fcntl.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>

#include "hisfm/io/colmap_version.h"
#include "hisfm/util/child_process.h"
#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"
#include "hisfm/util/interrupt.h"
#include "hisfm/util/logging.h"
#include "hisfm/util/timer.h"

namespace hisfm {

void ColmapRunnerOptions::Check() const {
  HISFM_CHECK_OPTION(colmap_path, !colmap_path.empty(), "non-empty");
}

namespace {

// This process's environment, plus GLOG_log_dir set to the folder of
// `log_path` (unless set already): colmap's own log files (glog) then go
// next to the log hisfm keeps, not into /tmp, where every run would leave
// two.
std::vector<std::string> ColmapEnvironment(const std::string& log_path) {
  std::vector<std::string> env = CurrentEnvironment();
  bool has_log_dir = false;
  for (const std::string& e : env) {
    has_log_dir |= e.rfind("GLOG_log_dir=", 0) == 0;
  }
  if (!has_log_dir) {
    const std::string dir =
        std::filesystem::absolute(log_path).parent_path().string();
    env.push_back("GLOG_log_dir=" + dir);
  }
  return env;
}

std::string JoinCommand(const std::vector<std::string>& argv) {
  std::string out;
  for (const std::string& a : argv) {
    if (!out.empty()) out += ' ';
    out += a;
  }
  return out;
}

}  // namespace

std::string CheckColmapAvailable(const ColmapRunnerOptions& options) {
  options.Check();
  return ProbeColmap(options.colmap_path, /*refresh=*/true).line;
}

double RunColmap(const ColmapRunnerOptions& options,
                 const std::vector<std::string>& args,
                 const std::string& log_path) {
  options.Check();
  // Options under the names of the colmap that runs (io/colmap_version.h).
  const std::vector<std::string> translated =
      TranslateColmapArguments(ProbeColmap(options.colmap_path).release, args);
  std::vector<std::string> argv = {options.colmap_path};
  argv.insert(argv.end(), translated.begin(), translated.end());
  const std::string command = JoinCommand(argv);
  HISFM_LOG_DEBUG("running: {}", command);
  const int fd = open(log_path.c_str(), O_WRONLY | O_CREAT | O_APPEND, 0644);
  ThrowUnless(fd >= 0, StrCat("cannot write log file ", log_path));
  {
    const std::string header = "$ " + command + "\n";
    (void)!write(fd, header.data(), header.size());
  }
  Timer timer;
  int spawn_error = 0;
  ThrowIfInterrupted();
  const int status =
      RunChildProcess(argv, ColmapEnvironment(log_path), fd, &spawn_error);
  close(fd);
  // A colmap stopped by Ctrl-C or SIGTERM is an interruption, not a failure.
  ThrowIfInterrupted();
  ThrowUnless(status >= 0, StrCat("colmap not found: cannot run '",
                                  options.colmap_path,
                                  "': ", std::strerror(spawn_error)));
  ThrowUnless(status == 0,
              StrCat("colmap failed (exit ", status, "): ", command,
                     " -- log ", log_path, ": ", TailOfFile(log_path, 4)));
  return timer.ElapsedSeconds();
}

}  // namespace hisfm
