#include "hisfm/util/test_util.h"

#include <stdlib.h>
#include <sys/wait.h>

#include <cstdint>
#include <filesystem>
#include <fstream>

#include "hisfm/util/error.h"

namespace fs = std::filesystem;

namespace hisfm {

std::string SharedDataDir() {
  if (const char* env = std::getenv("HISFM_DATA_DIR")) return env;
  // Tests run from build/ or build/tests: look upwards for ../shared/data.
  fs::path dir = fs::current_path();
  for (int i = 0; i < 5; ++i) {
    const fs::path candidate = dir.parent_path() / "shared" / "data";
    if (fs::exists(candidate)) return candidate.string();
    dir = dir.parent_path();
  }
  return (fs::path(HISFM_SOURCE_DIR) / ".." / "shared" / "data")
      .lexically_normal()
      .string();
}

std::string SharedDataPath(const std::string& scene, const std::string& file) {
  const fs::path p = fs::path(SharedDataDir()) / scene / file;
  return fs::exists(p) ? p.string() : "";
}

TempDir::TempDir(const std::string& tag) {
  std::string pattern = (fs::temp_directory_path() / (tag + "-XXXXXX")).string();
  path_ = mkdtemp(pattern.data()) ? pattern : "";
}

TempDir::~TempDir() {
  std::error_code ec;
  if (!path_.empty() && !std::getenv("HISFM_KEEP_TEST_FILES"))
    fs::remove_all(path_, ec);
}

int RunShell(const std::string& command, const std::string& log_path) {
  const std::string full =
      command + (log_path.empty() ? " > /dev/null 2>&1"
                                  : " > '" + log_path + "' 2>&1");
  const int status = std::system(full.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : 128;
}

bool ColmapAvailable() { return RunShell("colmap help") == 0; }

std::string UseLocalSlurmCluster() {
  if (RunShell("command -v sbatch && command -v squeue") != 0) {
    return "Slurm is not installed (scripts/setup.sh installs slurm-wlm and "
           "munge): the Slurm tests are skipped";
  }
  const char* binary_dir = std::getenv("HISFM_BINARY_DIR");
  const std::string env_file =
      std::string(binary_dir ? binary_dir : ".") + "/local_slurm.env";
  std::ifstream in(env_file);
  std::string line;
  std::getline(in, line);
  const std::string prefix = "export SLURM_CONF=";
  if (line.rfind(prefix, 0) != 0) {
    throw Error("Slurm is installed but no local cluster was started ("
                + env_file +
                " is missing or empty): run the test through ctest, whose "
                "fixture runs scripts/local_slurm.sh start");
  }
  const std::string conf = line.substr(prefix.size());
  setenv("SLURM_CONF", conf.c_str(), 1);
  if (RunShell("timeout 20 sinfo -h") != 0) {
    throw Error("the local Slurm cluster (SLURM_CONF=" + conf +
                ") does not answer: see its logs beside that file");
  }
  return "";
}

uint64_t FileFingerprint(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  uint64_t h = 1469598103934665603ull;
  char buf[1 << 16];
  while (in.read(buf, sizeof(buf)) || in.gcount() > 0) {
    for (std::streamsize i = 0; i < in.gcount(); ++i) {
      h ^= static_cast<unsigned char>(buf[i]);
      h *= 1099511628211ull;
    }
  }
  return h;
}

}  // namespace hisfm
