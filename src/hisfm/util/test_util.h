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

/// Points SLURM_CONF at the one-machine cluster that ctest starts with
/// scripts/local_slurm.sh (its `export SLURM_CONF=...` line is in
/// $HISFM_BINARY_DIR/local_slurm.env) and returns "" if it answers; else
/// returns why the Slurm tests are skipped (Slurm not installed). Throws
/// hisfm::Error if Slurm is installed but the cluster does not answer.
std::string UseLocalSlurmCluster();

/// SHA-like fingerprint of a file's bytes (FNV-1a 64), for "unchanged" checks.
uint64_t FileFingerprint(const std::string& path);

}  // namespace hisfm
