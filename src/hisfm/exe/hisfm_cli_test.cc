// Tests of the `hisfm` executable: exit codes, one-line errors, help texts.
#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "hisfm/util/file_util.h"
#include "hisfm/util/test_util.h"

namespace fs = std::filesystem;

namespace hisfm {
namespace {

std::string Hisfm() {
  const char* dir = std::getenv("HISFM_BINARY_DIR");
  return std::string(dir ? dir : ".") + "/hisfm";
}

struct Result {
  int code = 0;
  std::string output;
};

Result RunHisfm(const std::string& args, const TempDir& tmp) {
  Result r;
  r.code = RunShell(Hisfm() + " " + args, tmp / "log.txt");
  r.output = ReadTextFile(tmp / "log.txt");
  return r;
}

size_t NumLines(const std::string& s) {
  size_t n = 0;
  std::istringstream in(s);
  std::string line;
  while (std::getline(in, line)) n += !line.empty();
  return n;
}

TEST(HisfmCli, UsageAndUnknownCommand) {
  TempDir tmp;
  Result r = RunHisfm("", tmp);
  EXPECT_NE(r.code, 0);
  EXPECT_NE(r.output.find("mapper"), std::string::npos);
  r = RunHisfm("no_such_command", tmp);
  EXPECT_NE(r.code, 0);
  EXPECT_EQ(NumLines(r.output), 1u) << r.output;
}

TEST(HisfmCli, MapperHelpListsEveryOptionWithDefault) {
  TempDir tmp;
  const Result r = RunHisfm("mapper -h", tmp);
  EXPECT_EQ(r.code, 0);
  for (const char* flag :
       {"--database_path", "--image_path", "--output_path", "--HiSfM.top_k",
        "--HiSfM.num_trees", "--HiSfM.leaf_edges", "--HiSfM.min_num_matches",
        "--HiSfM.verify_threshold", "--HiSfM.verifier",
        "--HiSfM.num_top_bridges", "--HiSfM.num_backup_bridges"}) {
    EXPECT_NE(r.output.find(flag), std::string::npos) << flag;
  }
  EXPECT_NE(r.output.find("INT=15"), std::string::npos) << "defaults shown";
}

TEST(HisfmCli, BadInputIsOneLineAndNonZero) {
  TempDir tmp;
  fs::create_directories(tmp / "images");
  std::ofstream(tmp / "junk.db") << "not a database, just text\n";
  for (const std::string& db : {tmp / "missing.db", tmp / "junk.db"}) {
    const Result r = RunHisfm("mapper --database_path " + db + " --image_path " +
                             (tmp / "images") + " --output_path " +
                             (tmp / "out"),
                         tmp);
    EXPECT_NE(r.code, 0);
    EXPECT_EQ(NumLines(r.output), 1u) << r.output;
    EXPECT_EQ(r.output.rfind("error: ", 0), 0u) << r.output;
    EXPECT_FALSE(fs::exists(tmp / "out"));
  }
  const Result r = RunHisfm("mapper --database_path x.db", tmp);
  EXPECT_NE(r.code, 0) << "missing required flags";
  const Result bad_option =
      RunHisfm("mapper --database_path x.db --image_path . --output_path o "
          "--HiSfM.top_k 0",
          tmp);
  EXPECT_NE(bad_option.code, 0);
}

TEST(HisfmCli, ReconstructNeedsPhotos) {
  TempDir tmp;
  fs::create_directories(tmp / "empty");
  for (const std::string& dir : {tmp / "missing", tmp / "empty"}) {
    const Result r = RunHisfm("reconstruct --image_path " + dir +
                                  " --workspace_path " + (tmp / "ws"),
                              tmp);
    EXPECT_NE(r.code, 0) << dir;
    EXPECT_EQ(NumLines(r.output), 1u) << r.output;
    EXPECT_EQ(r.output.rfind("error: ", 0), 0u) << r.output;
  }
}

TEST(HisfmCli, EveryCommandHasHelp) {
  TempDir tmp;
  for (const char* command :
       {"mapper", "view_graph", "evaluate", "synth", "filter_pairs",
        "reconstruct", "demo", "report", "model_stats", "model_export",
        "model_converter"}) {
    const Result r = RunHisfm(std::string(command) + " -h", tmp);
    EXPECT_EQ(r.code, 0) << command;
    EXPECT_NE(r.output.find("Usage"), std::string::npos) << command;
  }
}

TEST(HisfmCli, ViewGraphWritesTheHierarchy) {
  const std::string db = SharedDataPath("yan2017/cup", "database.db");
  if (db.empty()) GTEST_SKIP() << "shared data not found: " << SharedDataDir();
  TempDir tmp;
  const Result r = RunHisfm("view_graph --database_path " + db +
                           " --HiSfM.verifier none --output_path " +
                           (tmp / "h.json"),
                       tmp);
  ASSERT_EQ(r.code, 0) << r.output;
  const std::string json = ReadTextFile(tmp / "h.json");
  for (const char* key : {"\"skeleton_bridges\"", "\"leaf_edges\"",
                          "\"rejected_bridges\"", "\"community\""}) {
    EXPECT_NE(json.find(key), std::string::npos) << key;
  }
}

}  // namespace
}  // namespace hisfm
