#include "hisfm/util/file_util.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "hisfm/util/error.h"
#include "hisfm/util/test_util.h"

namespace hisfm {
namespace {

namespace fs = std::filesystem;

size_t NumEntries(const std::string& folder) {
  size_t n = 0;
  for (const auto& entry : fs::directory_iterator(folder)) {
    (void)entry;
    ++n;
  }
  return n;
}

TEST(FileUtil, NormalizePathNamesOneFolderOneWay) {
  TempDir tmp("hisfm-file-util");
  fs::create_directories(tmp / "out");
  const std::string out = NormalizePath(tmp / "out");
  EXPECT_EQ(NormalizePath(tmp / "out/"), out);
  EXPECT_EQ(NormalizePath(tmp / "./out"), out);
  EXPECT_EQ(NormalizePath(tmp / "out/../out/."), out);
  EXPECT_EQ(out.back(), 't');
  // A link to the folder is the folder; a missing path is normalized too.
  fs::create_directory_symlink(tmp / "out", tmp / "link");
  EXPECT_EQ(NormalizePath(tmp / "link"), out);
  EXPECT_EQ(NormalizePath(tmp / "link/new/"), out + "/new");
  EXPECT_EQ(NormalizePath("/"), "/");
}

TEST(FileUtil, IsSameOrInside) {
  TempDir tmp("hisfm-file-util");
  EXPECT_TRUE(IsSameOrInside(tmp / "a", tmp / "a/"));
  EXPECT_TRUE(IsSameOrInside(tmp / "a/b/c.db", tmp / "a"));
  EXPECT_FALSE(IsSameOrInside(tmp / "ab", tmp / "a"));
  EXPECT_FALSE(IsSameOrInside(tmp / "a", tmp / "a/b"));
  EXPECT_TRUE(IsSameOrInside(tmp.path(), "/"));
}

TEST(FileUtil, PrepareWorkDirectoryNeverDeletesAUsersFolder) {
  TempDir tmp("hisfm-file-util");
  // A user's folder with content, and a file: refused, left as they were.
  fs::create_directories(tmp / "user");
  WriteFileAtomically(tmp / "user/precious.txt", "keep\n");
  EXPECT_THROW(PrepareWorkDirectory(tmp / "user"), Error);
  EXPECT_EQ(ReadTextFile(tmp / "user/precious.txt"), "keep\n");
  WriteFileAtomically(tmp / "file", "keep\n");
  EXPECT_THROW(PrepareWorkDirectory(tmp / "file"), Error);
  EXPECT_EQ(ReadTextFile(tmp / "file"), "keep\n");

  // A missing or empty folder is made a work folder; a work folder is
  // emptied on the next run.
  PrepareWorkDirectory(tmp / "work");
  EXPECT_EQ(NumEntries(tmp / "work"), 1u);  // The marker.
  WriteFileAtomically(tmp / "work/old.txt", "old\n");
  fs::create_directories(tmp / "work/component0");
  PrepareWorkDirectory(tmp / "work");
  EXPECT_EQ(NumEntries(tmp / "work"), 1u);
  fs::create_directories(tmp / "empty");
  PrepareWorkDirectory(tmp / "empty");
  EXPECT_EQ(NumEntries(tmp / "empty"), 1u);

  // A work folder of an earlier version, recognized by the file it held.
  fs::create_directories(tmp / "legacy/component0");
  WriteFileAtomically(tmp / "legacy/view_graph.json", "{}\n");
  EXPECT_THROW(PrepareWorkDirectory(tmp / "legacy"), Error);
  PrepareWorkDirectory(tmp / "legacy", "view_graph.json");
  EXPECT_EQ(NumEntries(tmp / "legacy"), 1u);
  EXPECT_THROW(PrepareWorkDirectory(tmp / "user", "view_graph.json"), Error);
}

TEST(FileUtil, WriteFileAtomicallyRefusesFoldersAndDatabases) {
  TempDir tmp("hisfm-file-util");
  fs::create_directories(tmp / "folder");
  EXPECT_THROW(WriteFileAtomically(tmp / "folder", "x"), Error);
  {
    std::ofstream db(tmp / "input.db", std::ios::binary);
    db << std::string("SQLite format 3\0rest of the header", 34);
  }
  EXPECT_THROW(WriteFileAtomically(tmp / "input.db", "{}\n"), Error);
  EXPECT_EQ(fs::file_size(tmp / "input.db"), 34u);
  // Ordinary files are replaced, and no temporary file is left behind, also
  // when writing fails (a missing parent folder).
  WriteFileAtomically(tmp / "out.json", "1\n");
  WriteFileAtomically(tmp / "out.json", "2\n");
  EXPECT_EQ(ReadTextFile(tmp / "out.json"), "2\n");
  EXPECT_THROW(WriteFileAtomically(tmp / "missing/out.json", "3\n"), Error);
  EXPECT_EQ(NumEntries(tmp.path()), 3u);
}

TEST(FileUtil, CheckOutputFileProtectsModelsAndInputs) {
  TempDir tmp("hisfm-file-util");
  fs::create_directories(tmp / "model");
  for (const char* file : {"cameras.bin", "images.bin", "points3D.bin"}) {
    std::ofstream(tmp / ("model/" + std::string(file))) << "model\n";
  }
  std::ofstream(tmp / "input.json") << "{}\n";
  // Files of a model, however named.
  EXPECT_THROW(CheckOutputFile(tmp / "model/images.bin"), Error);
  EXPECT_THROW(CheckOutputFile(tmp / "model/../model/points3D.bin"), Error);
  EXPECT_THROW(CheckOutputFile(tmp / "model/points3D.txt"), Error)
      << "would sit beside the binary model";
  fs::create_symlink(tmp / "model/cameras.bin", tmp / "link.bin");
  EXPECT_THROW(CheckOutputFile(tmp / "link.bin"), Error);
  // The same names outside a model folder are ordinary outputs.
  EXPECT_NO_THROW(CheckOutputFile(tmp / "images.bin"));
  // Inputs, their folders, and hard links to them.
  EXPECT_THROW(CheckOutputFile(tmp / "model/eval.json", {tmp / "model"}),
               Error);
  EXPECT_NO_THROW(CheckOutputFile(tmp / "model/eval.json"));
  EXPECT_THROW(CheckOutputFile(tmp / "input.json", {tmp / "input.json"}),
               Error);
  fs::create_hard_link(tmp / "input.json", tmp / "same.json");
  EXPECT_THROW(CheckOutputFile(tmp / "same.json", {tmp / "input.json"}),
               Error);
  EXPECT_NO_THROW(
      CheckOutputFile(tmp / "other.json", {tmp / "input.json", "", tmp / "model"}));
  for (const char* file : {"cameras.bin", "images.bin", "points3D.bin"}) {
    EXPECT_EQ(ReadTextFile(tmp / ("model/" + std::string(file))), "model\n");
  }
}

}  // namespace
}  // namespace hisfm
