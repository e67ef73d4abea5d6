// Tests of the `hisfm` executable: exit codes, one-line errors, help texts.
#include <gtest/gtest.h>
#include <sqlite3.h>

#include <nlohmann/json.hpp>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <utility>
#include <vector>

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

// Same as RunHisfm, from inside `dir` (for relative paths).
Result RunHisfmIn(const std::string& dir, const std::string& args,
                  const TempDir& tmp) {
  Result r;
  r.code = RunShell("cd '" + dir + "' && " + fs::absolute(Hisfm()).string() +
                        " " + args,
                    tmp / "log.txt");
  r.output = ReadTextFile(tmp / "log.txt");
  return r;
}

// Writes a synthetic street of `num_images` photos to tmp/`name`.
Result MakeScene(const TempDir& tmp, const std::string& name, int num_images,
                 int seed) {
  return RunHisfm("synth --output_path " + (tmp / name) +
                      " --scene street --num_images " +
                      std::to_string(num_images) + " --seed " +
                      std::to_string(seed),
                  tmp);
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
  EXPECT_EQ(NumLines(bad_option.output), 1u) << bad_option.output;
  EXPECT_EQ(bad_option.output,
            "error: invalid option --HiSfM.top_k = 0: must be >= 1\n");
  const Result bad_ratio = RunHisfm(
      "view_graph --database_path x.db --output_path o.json "
      "--HiSfM.filter_min_three_view_consistency=1.5",
      tmp);
  EXPECT_NE(bad_ratio.code, 0);
  EXPECT_EQ(bad_ratio.output,
            "error: invalid option --HiSfM.filter_min_three_view_consistency "
            "= 1.5: must be in [0, 1]\n");
  // Other commands' options too: synth's, reconstruct's.
  const Result bad_synth =
      RunHisfm("synth --output_path o --num_images 1", tmp);
  EXPECT_NE(bad_synth.code, 0);
  EXPECT_EQ(bad_synth.output,
            "error: invalid option --num_images = 1: must be >= 2\n");
  EXPECT_FALSE(fs::exists(tmp / "o"));
  const Result bad_words = RunHisfm(
      "reconstruct --image_path . --workspace_path w "
      "--vocab_tree_num_words 8",
      tmp);
  EXPECT_NE(bad_words.code, 0);
  EXPECT_EQ(bad_words.output,
            "error: invalid option --vocab_tree_num_words = 8: must be 0 or "
            ">= 16\n");
  EXPECT_FALSE(fs::exists(tmp / "w"));
  const Result bad_threshold = RunHisfm(
      "evaluate --model m --reference r --alignment_inlier_threshold 0", tmp);
  EXPECT_NE(bad_threshold.code, 0);
  EXPECT_EQ(bad_threshold.output,
            "error: invalid option --alignment_inlier_threshold = 0: must be "
            "> 0.0\n");
  const Result bad_batch = RunHisfm(
      "filter_pairs --database_path x.db --output_path y.db "
      "--HiSfM.verifier_batch_size 0",
      tmp);
  EXPECT_NE(bad_batch.code, 0);
  EXPECT_EQ(bad_batch.output,
            "error: invalid option --HiSfM.verifier_batch_size = 0: must be "
            ">= 1\n");
}

// Mistyped output and work paths must never delete or replace an input or a
// user's folder.
TEST(HisfmCli, OutputsNeverReplaceInputs) {
  TempDir tmp;
  ASSERT_EQ(MakeScene(tmp, "scene", 12, 1).code, 0);
  const std::string db = tmp / "scene/database.db";
  const uint64_t before = FileFingerprint(db);
  fs::create_directories(tmp / "user");
  std::ofstream(tmp / "user/precious.txt") << "keep\n";
  const std::string mapper = "mapper --database_path " + db +
                             " --image_path " + (tmp / "scene/images") +
                             " --output_path " + (tmp / "out");
  for (const std::string& command :
       {"view_graph --database_path " + db + " --output_path " + db,
        mapper + " --work_path " + (tmp / "scene"),
        mapper + " --work_path " + (tmp / "user"),
        mapper + " --work_path " + (tmp / "out/work"),
        mapper + " --work_path " + (tmp / "user/precious.txt")}) {
    const Result r = RunHisfm(command, tmp);
    EXPECT_NE(r.code, 0) << command;
    EXPECT_EQ(NumLines(r.output), 1u) << r.output;
    EXPECT_EQ(r.output.rfind("error: ", 0), 0u) << r.output;
  }
  EXPECT_EQ(FileFingerprint(db), before);
  EXPECT_TRUE(fs::is_directory(tmp / "scene/images"));
  EXPECT_TRUE(fs::exists(tmp / "user/precious.txt"));
  EXPECT_FALSE(fs::exists(tmp / "out"));
}

// What colmap would crash on is reported first, in one line.
TEST(HisfmCli, DatabasesColmapCannotUseAreErrors) {
  TempDir tmp;
  ASSERT_EQ(MakeScene(tmp, "scene", 12, 1).code, 0);
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"DELETE FROM keypoints WHERE image_id = 2;", "no keypoints"},
      {"DELETE FROM cameras;", "not in the cameras table"}};
  for (const auto& [sql, message] : cases) {
    const std::string db = tmp / "broken.db";
    fs::remove(db);
    fs::copy_file(tmp / "scene/database.db", db);
    sqlite3* handle = nullptr;
    ASSERT_EQ(sqlite3_open(db.c_str(), &handle), SQLITE_OK);
    ASSERT_EQ(sqlite3_exec(handle, sql.c_str(), nullptr, nullptr, nullptr),
              SQLITE_OK);
    sqlite3_close(handle);
    for (const std::string& command :
         {"view_graph --log_level warn --database_path " + db,
          "filter_pairs --log_level warn --database_path " + db +
              " --output_path " + (tmp / "filtered.db")}) {
      const Result r = RunHisfm(command, tmp);
      EXPECT_NE(r.code, 0) << sql;
      EXPECT_EQ(NumLines(r.output), 1u) << r.output;
      EXPECT_NE(r.output.find(message), std::string::npos) << r.output;
    }
  }
}

// SIGTERM to hisfm alone while colmap runs: colmap is stopped too, the run
// ends with 128 + 15 and one line, and neither the output nor its temporary
// folder is left.
TEST(HisfmCli, InterruptedMapperLeavesNoOutputAndNoColmap) {
  if (!ColmapAvailable()) GTEST_SKIP() << "colmap is not installed";
  TempDir tmp;
  ASSERT_EQ(MakeScene(tmp, "scene", 40, 1).code, 0);
  fs::create_directories(tmp / "results");
  const std::string out = tmp / "results/out";
  const std::string script =
      Hisfm() + " mapper --database_path " + (tmp / "scene/database.db") +
      " --image_path " + (tmp / "scene/images") + " --output_path " + out +
      " > " + (tmp / "mapper.txt") + " 2>&1 & P=$!; " +
      "for i in $(seq 1 1200); do [ -s " + out +
      "_work/component0/colmap.log ] && break; sleep 0.05; done; " +
      "sleep 0.3; kill -TERM $P; wait $P; echo $? > " + (tmp / "code.txt") +
      "; sleep 0.5; pgrep -f \"[c]olmap mapper .*" + out + "_work\" > " +
      (tmp / "left.txt");
  RunShell("bash -c '" + script + "'");
  EXPECT_EQ(ReadTextFile(tmp / "code.txt"), "143\n");
  const std::string log = ReadTextFile(tmp / "mapper.txt");
  EXPECT_NE(log.find("error: interrupted by signal 15"), std::string::npos)
      << log;
  EXPECT_EQ(ReadTextFile(tmp / "left.txt"), "") << "colmap still running";
  size_t num_entries = 0;
  for (const auto& entry : fs::directory_iterator(tmp / "results")) {
    EXPECT_EQ(entry.path().filename().string(), "out_work");
    ++num_entries;
  }
  EXPECT_EQ(num_entries, 1u);

  // Commands without colmap keep the default action: SIGTERM ends them, and
  // an ignored SIGHUP (nohup) stays ignored in the mapper too.
  const std::string synth =
      Hisfm() + " synth --output_path " + (tmp / "big") +
      " --scene street --num_images 20000 > /dev/null 2>&1 & P=$!; " +
      "sleep 0.3; kill -TERM $P; wait $P; echo $? > " + (tmp / "code.txt");
  RunShell("bash -c '" + synth + "'");
  EXPECT_EQ(ReadTextFile(tmp / "code.txt"), "143\n");
  const std::string nohup =
      "trap \"\" HUP; " + Hisfm() + " mapper --database_path " +
      (tmp / "scene/database.db") + " --image_path " +
      (tmp / "scene/images") + " --output_path " + (tmp / "results/nohup") +
      " > /dev/null 2>&1 & P=$!; sleep 0.5; kill -HUP $P; wait $P; echo $? > " +
      (tmp / "code.txt");
  RunShell("bash -c '" + nohup + "'");
  EXPECT_EQ(ReadTextFile(tmp / "code.txt"), "0\n");
}

// The hisfm_options.ini a run writes is read back by --project_path, with
// absolute paths and the --Mapper.* flags it passed to colmap.
TEST(HisfmCli, OptionsFileFeedsBack) {
  if (!ColmapAvailable()) GTEST_SKIP() << "colmap is not installed";
  TempDir tmp;
  ASSERT_EQ(MakeScene(tmp, "scene", 12, 2).code, 0);
  // Relative paths, from the temporary folder.
  const Result first = RunHisfmIn(
      tmp.path(),
      "mapper --database_path scene/database.db --image_path scene/images "
      "--output_path out1 --HiSfM.top_k 2 --Mapper.init_min_num_inliers 50",
      tmp);
  ASSERT_EQ(first.code, 0) << first.output;
  const std::string record = ReadTextFile(tmp / "out1/hisfm_options.ini");
  EXPECT_NE(record.find("database_path=\"" + (tmp / "scene/database.db")),
            std::string::npos)
      << record;
  EXPECT_NE(record.find("Mapper.init_min_num_inliers=50"), std::string::npos);

  // From another folder; the command line wins over the file.
  fs::create_directories(tmp / "elsewhere");
  const Result second = RunHisfmIn(
      tmp / "elsewhere",
      "mapper --project_path " + (tmp / "out1/hisfm_options.ini") +
          " --output_path " + (tmp / "out2") + " --work_path " +
          (tmp / "work2") + " --Mapper.ba_local_num_images 5",
      tmp);
  ASSERT_EQ(second.code, 0) << second.output;
  const std::string again = ReadTextFile(tmp / "out2/hisfm_options.ini");
  EXPECT_NE(again.find("HiSfM.top_k=2"), std::string::npos) << again;
  const std::string colmap_log =
      ReadTextFile(tmp / "work2/component0/colmap.log");
  EXPECT_NE(colmap_log.find("--Mapper.init_min_num_inliers 50"),
            std::string::npos);
  EXPECT_NE(colmap_log.find("--Mapper.ba_local_num_images 5"),
            std::string::npos);

  std::ofstream(tmp / "bad.ini") << "HiSfM.no_such_option=1\n";
  const Result bad =
      RunHisfm("mapper --project_path " + (tmp / "bad.ini"), tmp);
  EXPECT_NE(bad.code, 0);
  EXPECT_EQ(NumLines(bad.output), 1u) << bad.output;
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

// The builtin verifier rejects one trusted edge of the shared synthetic
// street (a doppelganger among the communities' strongest pairs); the JSON
// names it with its score, and the list agrees with the summary's count.
TEST(HisfmCli, ViewGraphListsTheRejectedTrustedEdges) {
  const std::string db =
      SharedDataPath("synthetic/facade_street_60", "database.db");
  if (db.empty()) GTEST_SKIP() << "shared data not found: " << SharedDataDir();
  TempDir tmp;
  const Result r = RunHisfm(
      "view_graph --database_path " + db + " --output_path " + (tmp / "h.json"),
      tmp);
  ASSERT_EQ(r.code, 0) << r.output;
  const nlohmann::json j = nlohmann::json::parse(ReadTextFile(tmp / "h.json"));
  const nlohmann::json& rejected = j.at("rejected_trusted_edges");
  ASSERT_TRUE(rejected.is_array());
  EXPECT_GE(rejected.size(), 1u);
  EXPECT_EQ(rejected.size(),
            j.at("summary").at("verification").at("rejected_trusted_edges")
                .get<size_t>());
  for (const nlohmann::json& e : rejected) {
    EXPECT_NE(e.at("image_id1"), e.at("image_id2"));
    EXPECT_GT(e.at("inliers").get<int>(), 0);
    // Rejected: below the trusted-edge threshold (default 0.25).
    EXPECT_LT(e.at("score").get<double>(), 0.25);
    EXPECT_GE(e.at("round").get<int>(), 0);
  }
}

}  // namespace
}  // namespace hisfm
