// Helpers shared by tests: the shared data folder, temporary folders, and
// running external commands.
#pragma once

#include <cstdint>
#include <string>

namespace hisfm {

/// HISFM_DATA_DIR, or ../shared/data relative to the project root.
std::string SharedDataDir();

/// Path of a scene's file under the data folder (e.g. "yan2017/cup",
/// "database.db"), or "" if it does not exist.
std::string SharedDataPath(const std::string& scene, const std::string& file);

/// A fresh, empty temporary folder removed by the destructor.
class TempDir {
 public:
  explicit TempDir(const std::string& tag = "hisfm-test");
  ~TempDir();
  const std::string& path() const { return path_; }
  std::string operator/(const std::string& name) const {
    return path_ + "/" + name;
  }

 private:
  std::string path_;
};

/// Runs a shell command, returns its exit code (output to `log_path` if not
/// empty, else discarded).
int RunShell(const std::string& command, const std::string& log_path = "");

/// True if `colmap` can be run.
bool ColmapAvailable();

/// SHA-like fingerprint of a file's bytes (FNV-1a 64), for "unchanged" checks.
uint64_t FileFingerprint(const std::string& path);

}  // namespace hisfm
