#include "hisfm/io/database_validation.h"

#include <gtest/gtest.h>
#include <sqlite3.h>

#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <limits>
#include <random>

#include "hisfm/io/database.h"
#include "hisfm/io/database_writer.h"
#include "hisfm/util/error.h"
#include "hisfm/util/test_util.h"

namespace fs = std::filesystem;

namespace hisfm {
namespace {

constexpr int kNumImages = 5;
constexpr int kNumKeypoints = 20;

// A valid database: one camera, kNumImages images of kNumKeypoints
// keypoints, descriptors, and raw and verified matches of every pair.
void WriteValidDatabase(const std::string& path, uint32_t seed) {
  std::mt19937 rng(seed);
  DatabaseWriter w(path);
  w.WriteCamera(SimplePinholeCamera(1, 640, 480, 500));
  for (int i = 1; i <= kNumImages; ++i) {
    w.WriteImage({ImageId(i), "img" + std::to_string(i) + ".jpg", 1});
    Keypoints kp(kNumKeypoints, 2);
    for (int r = 0; r < kp.rows(); ++r) {
      kp(r, 0) = rng() % 640;
      kp(r, 1) = rng() % 480;
    }
    w.WriteKeypoints(i, kp);
    Descriptors d(kNumKeypoints, 128);
    for (int r = 0; r < d.size(); ++r) d.data()[r] = rng() % 256;
    w.WriteDescriptors(i, d);
  }
  for (int i = 1; i <= kNumImages; ++i) {
    for (int j = i + 1; j <= kNumImages; ++j) {
      TwoViewGeometry g;
      g.pair = ImagePair(i, j);
      g.config = 2;
      for (int k = 0; k < 15; ++k) {
        g.inlier_matches.push_back({Point2DIdx(k), Point2DIdx(k + 1)});
      }
      g.F << 1, 2, 3, 4, 5, 6, 7, 8, 9;
      g.E = g.F;
      g.H = g.F;
      g.qvec << 1, 0, 0, 0;
      w.WriteMatches(g.pair, g.inlier_matches);
      w.WriteTwoViewGeometry(g);
    }
  }
  w.Close();
}

// Runs `sql` on the database; `blob`, if not empty, is bound to its `?`.
void Exec(const std::string& path, const std::string& sql,
          const std::string& blob = "") {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &db), SQLITE_OK);
  sqlite3_stmt* stmt = nullptr;
  const char* tail = sql.c_str();
  while (*tail) {
    ASSERT_EQ(sqlite3_prepare_v2(db, tail, -1, &stmt, &tail), SQLITE_OK)
        << sqlite3_errmsg(db) << " in " << sql;
    if (!stmt) break;
    if (!blob.empty()) {
      sqlite3_bind_blob(stmt, 1, blob.data(), blob.size(), SQLITE_TRANSIENT);
    }
    const int rc = sqlite3_step(stmt);
    EXPECT_TRUE(rc == SQLITE_DONE || rc == SQLITE_ROW) << sqlite3_errmsg(db);
    sqlite3_finalize(stmt);
  }
  sqlite3_close(db);
}

template <typename T>
std::string Bytes(const std::vector<T>& values) {
  return std::string(reinterpret_cast<const char*>(values.data()),
                     values.size() * sizeof(T));
}

// The keypoints of image 3 with one value replaced.
std::string KeypointsWith(float value) {
  std::vector<float> v(2 * kNumKeypoints, 1.0f);
  v[7] = value;
  return Bytes(v);
}

std::string MatrixWith(int n, double value) {
  std::vector<double> v(n, 0.5);
  v[n - 1] = value;
  return Bytes(v);
}

class DatabaseValidationTest : public ::testing::Test {
 protected:
  void SetUp() override {
    path_ = tmp_ / "db.db";
    Restore();
  }

  // Replaces the test's database with a fresh valid one (written once per
  // test program: writing syncs the file, copying does not).
  void Restore() {
    static const TempDir kTemplate("hisfm-valid-db");
    static const bool kWritten = [] {
      WriteValidDatabase(kTemplate / "valid.db", 7);
      return true;
    }();
    ASSERT_TRUE(kWritten);
    fs::copy_file(kTemplate / "valid.db", path_,
                  fs::copy_options::overwrite_existing);
  }

  // The problems after `sql` (with `blob` bound).
  std::vector<DatabaseProblem> After(const std::string& sql,
                                     const std::string& blob = "") {
    Exec(path_, sql, blob);
    return ValidateDatabase(path_);
  }

  TempDir tmp_;
  std::string path_;
};

// One problem, in `table`, row `id`, with `message` in its text.
void ExpectOne(const std::vector<DatabaseProblem>& problems,
               const std::string& table, const std::string& id,
               const std::string& message) {
  ASSERT_EQ(problems.size(), 1u);
  EXPECT_EQ(problems[0].table, table) << FormatDatabaseProblem(problems[0]);
  EXPECT_EQ(problems[0].id, id) << FormatDatabaseProblem(problems[0]);
  EXPECT_NE(problems[0].message.find(message), std::string::npos)
      << FormatDatabaseProblem(problems[0]);
}

TEST_F(DatabaseValidationTest, ValidDatabaseHasNoProblems) {
  EXPECT_TRUE(ValidateDatabase(path_).empty());
  EXPECT_NO_THROW(RequireValidDatabase(path_));
  // Zero keypoints and unverified pairs (rows 0, no blobs) are fine.
  Exec(path_,
       "UPDATE keypoints SET rows = 0, data = NULL WHERE image_id = 5; "
       "UPDATE descriptors SET rows = 0, data = NULL WHERE image_id = 5; "
       "DELETE FROM matches WHERE pair_id % 2147483647 = 5; "
       "UPDATE two_view_geometries SET rows = 0, data = NULL, config = 0, "
       "F = NULL, E = NULL, H = NULL, qvec = NULL, tvec = NULL WHERE "
       "pair_id % 2147483647 = 5;");
  EXPECT_TRUE(ValidateDatabase(path_).empty());
}

TEST_F(DatabaseValidationTest, KeypointRowCountsMustMatchTheirBlobs) {
  for (const char* rows : {"2147483647", "9223372036854775807", "-1", "21"}) {
    Restore();
    const auto problems = After(
        StrCat("UPDATE keypoints SET rows = ", rows, " WHERE image_id = 2"));
    ASSERT_EQ(problems.size(), 1u) << rows;
    EXPECT_EQ(problems[0].table, "keypoints");
    EXPECT_EQ(problems[0].id, "image 2");
  }
}

TEST_F(DatabaseValidationTest, TruncatedKeypoints) {
  ExpectOne(After("UPDATE keypoints SET data = substr(data, 1, 13) WHERE "
                  "image_id = 4"),
            "keypoints", "image 4",
            "rows x cols = 20 x 2 floats does not match its 13-byte");
}

TEST_F(DatabaseValidationTest, KeypointColumnsColmapDoesNotKnow) {
  // 20 x 2 floats are also 10 x 4: the size matches, cols 3 does not.
  ExpectOne(After("UPDATE keypoints SET cols = 3 WHERE image_id = 1"),
            "keypoints", "image 1", "cols 3 is not 2 or 4 or 6");
  ExpectOne(After("UPDATE keypoints SET cols = 5, rows = 8 WHERE image_id = "
                  "1"),
            "keypoints", "image 1", "cols 5 is not 2 or 4 or 6");
  EXPECT_TRUE(After("UPDATE keypoints SET cols = 4, rows = 10 WHERE "
                    "image_id = 1; UPDATE descriptors SET rows = 10, data = "
                    "substr(data, 1, 1280) WHERE image_id = 1; DELETE FROM "
                    "matches; DELETE FROM two_view_geometries")
                  .empty())
      << "4 columns (x, y, scale, orientation) are COLMAP's";
}

TEST_F(DatabaseValidationTest, NonFiniteKeypointsRefuseTheDatabase) {
  for (const float value : {std::numeric_limits<float>::quiet_NaN(),
                            std::numeric_limits<float>::infinity(),
                            -std::numeric_limits<float>::infinity()}) {
    const auto problems =
        After("UPDATE keypoints SET data = ? WHERE image_id = 3",
              KeypointsWith(value));
    ExpectOne(problems, "keypoints", "image 3",
              "keypoint 3 has a non-finite value");
    EXPECT_NE(problems[0].message.find("refuses"), std::string::npos);
  }
  std::vector<float> all_nan(2 * kNumKeypoints,
                             std::numeric_limits<float>::quiet_NaN());
  ExpectOne(
      After("UPDATE keypoints SET data = ? WHERE image_id = 3", Bytes(all_nan)),
      "keypoints", "image 3", "keypoint 0 has a non-finite value");
}

TEST_F(DatabaseValidationTest, KeypointsAndDescriptorsOfMissingImages) {
  ExpectOne(After("INSERT INTO keypoints VALUES (9, 0, 2, NULL)"), "keypoints",
            "image 9", "not in the images table");
  ExpectOne(After("DELETE FROM keypoints WHERE image_id = 9; INSERT INTO "
                  "descriptors VALUES (9, 0, 128, NULL)"),
            "descriptors", "image 9", "not in the images table");
}

TEST_F(DatabaseValidationTest, DescriptorsHave128ColumnsOnePerKeypoint) {
  ExpectOne(After("UPDATE descriptors SET cols = 64, rows = 40 WHERE "
                  "image_id = 2"),
            "descriptors", "image 2", "cols 64 is not 128");
  ExpectOne(After("UPDATE descriptors SET cols = 128, rows = 10, data = "
                  "substr(data, 1, 1280) WHERE image_id = 2"),
            "descriptors", "image 2", "10 descriptors for 20 keypoints");
}

TEST_F(DatabaseValidationTest, TwoViewGeometryShapes) {
  const std::string pair = "WHERE pair_id = 2147483647 * 2 + 4";
  ExpectOne(After("UPDATE two_view_geometries SET cols = 3 " + pair),
            "two_view_geometries", "images 2 and 4", "cols 3 is not 2");
  ExpectOne(After("UPDATE two_view_geometries SET cols = 2, rows = 16 " + pair),
            "two_view_geometries", "images 2 and 4",
            "rows x cols = 16 x 2 uint32 does not match its 120-byte");
  ExpectOne(
      After("UPDATE two_view_geometries SET rows = 15, F = x'00' " + pair),
      "two_view_geometries", "images 2 and 4",
      "F holds 1 bytes instead of 9 doubles");
  ExpectOne(
      After("UPDATE two_view_geometries SET F = NULL, config = 99 " + pair),
      "two_view_geometries", "images 2 and 4",
      "config 99 is not a COLMAP two-view configuration");
  ExpectOne(After("UPDATE two_view_geometries SET config = -1 " + pair),
            "two_view_geometries", "images 2 and 4", "config -1");
}

TEST_F(DatabaseValidationTest, NonFiniteMatricesAndPoses) {
  const std::string pair = " WHERE pair_id = 2147483647 * 1 + 3";
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const std::vector<std::pair<std::string, int>> columns = {
      {"F", 9}, {"E", 9}, {"H", 9}, {"qvec", 4}, {"tvec", 3}};
  for (const auto& [column, n] : columns) {
    for (const double value : {nan, inf}) {
      Restore();
      ExpectOne(
          After("UPDATE two_view_geometries SET " + column + " = ?" + pair,
                MatrixWith(n, value)),
          "two_view_geometries", "images 1 and 3",
          column + " has a non-finite value");
    }
  }
}

TEST_F(DatabaseValidationTest, MatchIndicesPastTheKeypoints) {
  std::vector<uint32_t> matches(30, 1);
  matches[2 * 6 + 1] = kNumKeypoints;  // Match 6, second image.
  const auto problems = After(
      "UPDATE two_view_geometries SET data = ? WHERE pair_id = "
      "2147483647 * 2 + 5; UPDATE matches SET data = ? WHERE pair_id "
      "= 2147483647 * 1 + 2",
      Bytes(matches));
  ASSERT_EQ(problems.size(), 2u);
  EXPECT_EQ(FormatDatabaseProblem(problems[0]),
            "two_view_geometries, images 2 and 5: match 6 names keypoint 20 "
            "of image 5, which has 20 keypoints");
  EXPECT_EQ(FormatDatabaseProblem(problems[1]),
            "matches, images 1 and 2: match 6 names keypoint 20 of image 2, "
            "which has 20 keypoints");
  DatabaseValidationOptions options;
  options.check_matches = false;
  EXPECT_EQ(ValidateDatabase(path_, options).size(), 1u);
}

TEST_F(DatabaseValidationTest, PairIdsNameTwoExistingImages) {
  const std::string values = ", 0, 2, NULL, 0, NULL, NULL, NULL, NULL, NULL)";
  ExpectOne(After("INSERT INTO two_view_geometries VALUES (2147483647 * 2 + "
                  "9" +
                  values),
            "two_view_geometries", "images 2 and 9",
            "image 9 is not in the images table");
  ExpectOne(After("DELETE FROM two_view_geometries WHERE pair_id = "
                  "2147483647 * 2 + 9; INSERT INTO two_view_geometries "
                  "VALUES (2147483647 * 3 + 3" +
                  values),
            "two_view_geometries", "images 3 and 3",
            "pairs image 3 with itself");
  ExpectOne(After("DELETE FROM two_view_geometries WHERE pair_id = "
                  "2147483647 * 3 + 3; INSERT INTO matches VALUES "
                  "(2147483647 * 4 + 2, 0, 2, NULL)"),
            "matches", "pair_id 8589934590",
            "is not COLMAP's id of images 2 and 4");
  ExpectOne(After("DELETE FROM matches WHERE pair_id = 8589934590; INSERT "
                  "INTO matches VALUES (-5, 0, 2, NULL)"),
            "matches", "pair_id -5", "names no two images");
}

TEST_F(DatabaseValidationTest, ImagesWithVerifiedPairsNeedKeypoints) {
  const auto problems = After(
      "DELETE FROM keypoints WHERE image_id = 5; "
      "DELETE FROM descriptors WHERE image_id = 5");
  // Four verified pairs and four raw ones with image 5.
  ASSERT_EQ(problems.size(), 8u);
  EXPECT_EQ(FormatDatabaseProblem(problems[0]),
            "two_view_geometries, images 1 and 5: image 5 has verified pairs "
            "but no keypoints");
}

TEST_F(DatabaseValidationTest, Cameras) {
  auto problems = After("UPDATE cameras SET width = 0, height = -3");
  ASSERT_EQ(problems.size(), 2u);
  EXPECT_EQ(FormatDatabaseProblem(problems[0]),
            "cameras, camera 1: width 0 is not a positive image size");
  EXPECT_EQ(FormatDatabaseProblem(problems[1]),
            "cameras, camera 1: height -3 is not a positive image size");
  ExpectOne(After("UPDATE cameras SET width = 640, height = 480, model = 99"),
            "cameras", "camera 1", "model 99 is not a COLMAP camera model");
  ExpectOne(After("UPDATE cameras SET model = 2"), "cameras", "camera 1",
            "params hold 24 bytes; SIMPLE_RADIAL has 4 parameters");
  ExpectOne(After("UPDATE cameras SET model = 0, params = ?",
                  MatrixWith(3, std::numeric_limits<double>::infinity())),
            "cameras", "camera 1", "parameter 2 is inf");
  std::vector<double> zero_focal = {0, 320, 240};
  ExpectOne(After("UPDATE cameras SET params = ?", Bytes(zero_focal)),
            "cameras", "camera 1", "focal length 0 is not positive");
}

TEST_F(DatabaseValidationTest, ImagesNeedTheirCameraAndAName) {
  ExpectOne(After("UPDATE images SET camera_id = 4 WHERE image_id = 2"),
            "images", "image 2",
            "refers to camera 4, which is not in the cameras table");
  ExpectOne(After("UPDATE images SET camera_id = 1, name = 'a\nb.jpg' WHERE "
                  "image_id = 2"),
            "images", "image 2", "line break");
  ExpectOne(After("UPDATE images SET name = '' WHERE image_id = 2"), "images",
            "image 2", "name is empty");
  ExpectOne(After("UPDATE images SET name = 'b.jpg ' WHERE image_id = 2"),
            "images", "image 2", "name begins or ends with a space");
}

// COLMAP's schema makes names unique; a database written by another tool
// may not, and hisfm's intermediate databases would then fail on it.
TEST_F(DatabaseValidationTest, DuplicateNames) {
  const std::string path = tmp_ / "loose.db";
  std::string schema;
  for (std::string sql : ColmapSchemaStatements()) {
    if (sql.find("INDEX") != std::string::npos) continue;
    const size_t unique = sql.find("NOT NULL UNIQUE");
    if (unique != std::string::npos) sql.replace(unique, 15, "NOT NULL");
    schema += sql;
  }
  Exec(path, schema);
  Exec(path,
       "INSERT INTO cameras VALUES (1, 0, 640, 480, ?, 1); INSERT INTO images "
       "(image_id, name, camera_id) VALUES (1, 'a.jpg', 1), (2, 'b.jpg', 1), "
       "(3, 'a.jpg', 1);",
       MatrixWith(3, 300));
  ExpectOne(ValidateDatabase(path), "images", "image 3",
            "name 'a.jpg' is also the name of image 1");
}

TEST_F(DatabaseValidationTest, TablesThatAreNotColmapsSchema) {
  ExpectOne(After("UPDATE keypoints SET rows = 'many' WHERE image_id = 1"),
            "keypoints", "image 1", "rows 'many' is not a count");
  ExpectOne(After("UPDATE keypoints SET rows = 20, data = 'text' WHERE "
                  "image_id = 1"),
            "keypoints", "image 1", "data is text, not a blob");
  const std::string path = path_;
  Restore();
  Exec(path,
       "CREATE TABLE copy AS SELECT * FROM two_view_geometries; DROP TABLE "
       "two_view_geometries; ALTER TABLE copy RENAME TO two_view_geometries; "
       "UPDATE two_view_geometries SET pair_id = pair_id + 1 WHERE rowid = "
       "3;");
  ExpectOne(ValidateDatabase(path), "two_view_geometries", "",
            "pair_id is not the table's INTEGER PRIMARY KEY");
  Restore();
  ExpectOne(After("ALTER TABLE cameras DROP COLUMN prior_focal_length"),
            "cameras", "",
            "cannot be read: no such column: prior_focal_length");
  // An unreadable table is named once, not once more for each reference.
  Restore();
  ExpectOne(After("ALTER TABLE keypoints DROP COLUMN cols"), "keypoints", "",
            "cannot be read: no such column: cols");
}

TEST_F(DatabaseValidationTest, CorruptFileIsNamedAsSuch) {
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(path_.c_str(), &db), SQLITE_OK);
  sqlite3_stmt* stmt = nullptr;
  sqlite3_prepare_v2(db,
                     "SELECT rootpage FROM sqlite_master WHERE name = "
                     "'two_view_geometries'",
                     -1, &stmt, nullptr);
  ASSERT_EQ(sqlite3_step(stmt), SQLITE_ROW);
  const int root = sqlite3_column_int(stmt, 0);
  sqlite3_finalize(stmt);
  sqlite3_prepare_v2(db, "PRAGMA page_size", -1, &stmt, nullptr);
  ASSERT_EQ(sqlite3_step(stmt), SQLITE_ROW);
  const int page_size = sqlite3_column_int(stmt, 0);
  sqlite3_finalize(stmt);
  sqlite3_close(db);
  {
    // The root page's type byte: no valid b-tree page type.
    std::fstream file(path_, std::ios::in | std::ios::out | std::ios::binary);
    file.seekp(static_cast<std::streamoff>(root - 1) * page_size);
    file.put(static_cast<char>(0x42));
  }
  const auto problems = ValidateDatabase(path_);
  ASSERT_FALSE(problems.empty());
  EXPECT_EQ(problems[0].table, "two_view_geometries");
  EXPECT_NE(problems[0].message.find("the file is corrupt"), std::string::npos)
      << FormatDatabaseProblem(problems[0]);
  EXPECT_EQ(problems[0].message.find("-wal"), std::string::npos);
}

TEST_F(DatabaseValidationTest, FilesThatAreNoDatabaseThrow) {
  EXPECT_THROW(ValidateDatabase(tmp_ / "missing.db"), Error);
  std::ofstream(tmp_ / "text.db") << "not a database\n";
  EXPECT_THROW(ValidateDatabase(tmp_ / "text.db"), Error);
}

// Many pairs (several chunks on two connections): problems come in pair
// order, and a limit returns the first ones.
TEST(DatabaseValidation, ProblemsComeInOrderAndStopAtTheLimit) {
  TempDir tmp;
  const std::string path = tmp / "many.db";
  constexpr int kImages = 120;
  {
    DatabaseWriter w(path);
    w.WriteCamera(SimplePinholeCamera(1, 100, 100, 80));
    for (int i = 1; i <= kImages; ++i) {
      w.WriteImage({ImageId(i), StrCat("i", i), 1});
      w.WriteKeypoints(i, Keypoints::Constant(4, 2, 10.0f));
    }
    for (int i = 1; i <= kImages; ++i) {
      for (int j = i + 1; j <= std::min(kImages, i + 3); ++j) {
        TwoViewGeometry g;
        g.pair = ImagePair(i, j);
        g.config = 2;
        // Every 17th first image: an index past its 4 keypoints.
        g.inlier_matches = {{0, 1}, {Point2DIdx(i % 17 == 0 ? 4 : 2), 3}};
        w.WriteTwoViewGeometry(g);
      }
    }
  }
  std::vector<std::string> expected;
  for (int i = 17; i <= kImages; i += 17) {
    for (int j = i + 1; j <= std::min(kImages, i + 3); ++j) {
      expected.push_back(StrCat("images ", i, " and ", j));
    }
  }
  const auto all = ValidateDatabase(path);
  std::vector<std::string> ids;
  for (const DatabaseProblem& p : all) ids.push_back(p.id);
  EXPECT_EQ(ids, expected);
  for (const int limit : {1, 2, 5}) {
    DatabaseValidationOptions options;
    options.max_problems = limit;
    const auto first = ValidateDatabase(path, options);
    ASSERT_EQ(first.size(), static_cast<size_t>(limit));
    for (int k = 0; k < limit; ++k) {
      EXPECT_EQ(first[k].id, all[k].id);
    }
  }
  try {
    RequireValidDatabase(path);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              "invalid database " + path +
                  ": two_view_geometries, images 17 and 18: match 1 names "
                  "keypoint 4 of image 17, which has 4 keypoints (hisfm "
                  "check_database lists every problem)");
  }
}

TEST(DatabaseValidation, SharedScenesAreValid) {
  for (const char* scene : {"yan2017/books", "yan2017/cup"}) {
    const std::string path = SharedDataPath(scene, "database.db");
    if (path.empty()) GTEST_SKIP() << "shared data not found";
    const uint64_t before = FileFingerprint(path);
    EXPECT_TRUE(ValidateDatabase(path).empty()) << scene;
    EXPECT_EQ(FileFingerprint(path), before);
  }
}

TEST(DatabaseValidation, OptionsAreChecked) {
  DatabaseValidationOptions options;
  EXPECT_NO_THROW(options.Check());
  options.max_problems = -1;
  EXPECT_THROW(options.Check(), Error);
}

}  // namespace
}  // namespace hisfm
