#include "hisfm/io/database.h"

#include <gtest/gtest.h>
#include <sqlite3.h>

#include <algorithm>
#include <filesystem>
#include <random>
#include <set>

#include "hisfm/io/database_writer.h"
#include "hisfm/util/error.h"
#include "hisfm/util/test_util.h"

namespace hisfm {
namespace {

// A small database with random content, written by DatabaseWriter.
void WriteRandomDatabase(const std::string& path, int num_images,
                         uint32_t seed) {
  std::mt19937 rng(seed);
  DatabaseWriter w(path);
  DatabaseCamera cam;
  cam.camera_id = 1;
  cam.model_id = 2;
  cam.width = 640;
  cam.height = 480;
  cam.params = {500, 320, 240, 0.01};
  cam.prior_focal_length = true;
  w.WriteCamera(cam);
  for (int i = 1; i <= num_images; ++i) {
    w.WriteImage({ImageId(i), "img" + std::to_string(i) + ".jpg", 1});
    Keypoints kp(20 + i, 2);
    for (int r = 0; r < kp.rows(); ++r) {
      kp(r, 0) = rng() % 640;
      kp(r, 1) = rng() % 480;
    }
    w.WriteKeypoints(i, kp);
    Descriptors d(kp.rows(), 128);
    for (int r = 0; r < d.size(); ++r) d.data()[r] = rng() % 256;
    w.WriteDescriptors(i, d);
  }
  for (int i = 1; i <= num_images; ++i) {
    for (int j = i + 1; j <= num_images; ++j) {
      TwoViewGeometry g;
      g.pair = ImagePair(i, j);
      g.config = 2;
      for (int k = 0; k < 15 + (i * j) % 7; ++k) {
        g.inlier_matches.push_back({Point2DIdx(k), Point2DIdx(k + 1)});
      }
      g.F << 1, 2, 3, 4, 5, 6, 7, 8, 9;
      g.E = g.F * 2;
      g.H = g.F * 3;
      w.WriteMatches(g.pair, g.inlier_matches);
      w.WriteTwoViewGeometry(g);
    }
  }
  w.Close();
}

std::vector<std::string> SchemaOf(const std::string& path) {
  sqlite3* db = nullptr;
  sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READONLY, nullptr);
  sqlite3_stmt* stmt = nullptr;
  sqlite3_prepare_v2(db,
                     "SELECT name, sql FROM sqlite_master WHERE sql IS NOT "
                     "NULL ORDER BY name",
                     -1, &stmt, nullptr);
  std::vector<std::string> out;
  while (sqlite3_step(stmt) == SQLITE_ROW) {
    std::string sql = reinterpret_cast<const char*>(sqlite3_column_text(stmt, 1));
    // COLMAP uses CREATE TABLE IF NOT EXISTS; SQLite stores the text without
    // the clause.
    out.push_back(sql);
  }
  sqlite3_finalize(stmt);
  sqlite3_close(db);
  return out;
}

TEST(Database, WriteThenReadRoundTrip) {
  TempDir tmp;
  const std::string path = tmp / "db.db";
  WriteRandomDatabase(path, 6, 1);
  Database db(path);
  const auto cameras = db.ReadCameras();
  ASSERT_EQ(cameras.size(), 1u);
  EXPECT_EQ(cameras[0].model_id, 2);
  EXPECT_EQ(cameras[0].params, (std::vector<double>{500, 320, 240, 0.01}));
  const auto images = db.ReadImages();
  ASSERT_EQ(images.size(), 6u);
  EXPECT_EQ(images[2].name, "img3.jpg");
  EXPECT_EQ(db.ReadKeypoints(3).rows(), 23);
  EXPECT_EQ(db.ReadDescriptors(3).cols(), 128);
  EXPECT_EQ(db.NumVerifiedPairs(), 15u);
  const auto pairs = db.ReadVerifiedPairs(18);
  for (const VerifiedPair& p : pairs) EXPECT_GE(p.num_inliers, 18u);
  const TwoViewGeometry g = db.ReadTwoViewGeometry(4, 2);
  EXPECT_EQ(g.pair, ImagePair(2, 4));
  EXPECT_EQ(g.inlier_matches.size(), 15u + 8 % 7);
  EXPECT_EQ(g.F(0, 1), 2.0);  // Row-major storage.
  EXPECT_EQ(g.F(1, 0), 4.0);
  EXPECT_EQ(g.H(2, 2), 27.0);
  EXPECT_EQ(db.ReadMatches(2, 4).size(), g.inlier_matches.size());
  EXPECT_THROW(db.ReadTwoViewGeometry(1, 99), Error);
}

TEST(Database, BulkAndInlierReadsAgreeWithFullReads) {
  TempDir tmp;
  const std::string path = tmp / "db.db";
  WriteRandomDatabase(path, 7, 2);
  Database db(path);
  // All verified pairs, in pair order, with the row counts of full reads.
  const std::vector<VerifiedPair> all = db.ReadVerifiedPairs(1);
  ASSERT_EQ(all.size(), 21u);
  for (size_t k = 0; k < all.size(); ++k) {
    if (k > 0) {
      EXPECT_LT(ImagePairToPairId(all[k - 1].pair.image_id1,
                                  all[k - 1].pair.image_id2),
                ImagePairToPairId(all[k].pair.image_id1,
                                  all[k].pair.image_id2));
    }
    const TwoViewGeometry g =
        db.ReadTwoViewGeometry(all[k].pair.image_id1, all[k].pair.image_id2);
    EXPECT_EQ(all[k].num_inliers, g.inlier_matches.size());
  }
  // Inlier-only reads, in either order of the ids.
  const TwoViewGeometry g = db.ReadTwoViewGeometry(3, 6);
  const std::vector<FeatureMatch> inliers = db.ReadInlierMatches(6, 3);
  ASSERT_EQ(inliers.size(), g.inlier_matches.size());
  for (size_t k = 0; k < inliers.size(); ++k) {
    EXPECT_EQ(inliers[k].idx1, g.inlier_matches[k].idx1);
    EXPECT_EQ(inliers[k].idx2, g.inlier_matches[k].idx2);
  }
  EXPECT_THROW(db.ReadInlierMatches(1, 99), Error);
  // Bulk reads: requested pairs present in the database, each once, in
  // pair-id order, oriented as stored.
  std::vector<ImagePair> requested = {ImagePair(5, 2), ImagePair(1, 99),
                                      ImagePair(1, 3), ImagePair(2, 5),
                                      ImagePair(7, 6)};
  std::vector<ImagePair> visited;
  {
    const Database::ReadScope outer(db);
    const Database::ReadScope nested(db);
    db.ForEachInlierMatches(
        requested, [&](const ImagePair& pair,
                       FeatureMatchSpan matches) {
          visited.push_back(pair);
          const TwoViewGeometry full =
              db.ReadTwoViewGeometry(pair.image_id1, pair.image_id2);
          ASSERT_EQ(matches.size(), full.inlier_matches.size());
          for (size_t k = 0; k < matches.size(); ++k) {
            EXPECT_EQ(matches[k].idx1, full.inlier_matches[k].idx1);
            EXPECT_EQ(matches[k].idx2, full.inlier_matches[k].idx2);
          }
        });
  }
  EXPECT_EQ(visited, (std::vector<ImagePair>{ImagePair(1, 3), ImagePair(2, 5),
                                             ImagePair(6, 7)}));
  // Reads still work after the scopes ended.
  EXPECT_EQ(db.ReadInlierMatches(3, 6).size(), g.inlier_matches.size());
  const std::unordered_map<ImageId, size_t> num_keypoints =
      db.ReadNumKeypoints();
  ASSERT_EQ(num_keypoints.size(), 7u);
  for (const auto& [id, n] : num_keypoints) {
    EXPECT_EQ(n, static_cast<size_t>(db.ReadKeypoints(id).rows()));
  }
}

// Enough pairs for the bulk read to read ahead on a second connection: the
// same pairs, contents and order as the one-connection read, and an
// exception thrown by the callback stops the reader and reaches the caller.
TEST(Database, BulkReadsOfManyPairsReadAhead) {
  TempDir tmp;
  const std::string path = tmp / "db.db";
  WriteRandomDatabase(path, 100, 3);
  Database db(path);
  std::vector<ImagePair> requested;
  for (ImageId i = 100; i >= 1; --i) {
    for (ImageId j = 100; j > i; --j) requested.push_back(ImagePair(j, i));
  }
  requested.push_back(ImagePair(1, 101));  // absent
  ASSERT_EQ(requested.size(), 4951u);
  std::vector<PairId> visited;
  db.ForEachInlierMatches(
      requested,
      [&](const ImagePair& pair, FeatureMatchSpan matches) {
        visited.push_back(ImagePairToPairId(pair.image_id1, pair.image_id2));
        const size_t expected =
            15 + (pair.image_id1 * pair.image_id2) % 7;
        ASSERT_EQ(matches.size(), expected);
        for (size_t k = 0; k < matches.size(); ++k) {
          EXPECT_EQ(matches[k].idx1, k);
          EXPECT_EQ(matches[k].idx2, k + 1);
        }
      });
  ASSERT_EQ(visited.size(), 4950u);
  EXPECT_TRUE(std::is_sorted(visited.begin(), visited.end()));
  EXPECT_EQ(visited.front(), ImagePairToPairId(1, 2));
  EXPECT_EQ(visited.back(), ImagePairToPairId(99, 100));

  size_t num_calls = 0;
  EXPECT_THROW(db.ForEachInlierMatches(
                   requested,
                   [&](const ImagePair&, FeatureMatchSpan) {
                     if (++num_calls == 3000) throw Error("stop here");
                   }),
               Error);
  EXPECT_EQ(num_calls, 3000u);
  // on_read sees every pair as it is read, in the same order and with the
  // same matches as fn, on the reading thread; an exception it throws there
  // stops the read and reaches the caller.
  std::vector<PairId> read_order;
  size_t num_mismatches = 0;
  db.ForEachInlierMatches(
      requested, [](const ImagePair&, FeatureMatchSpan) {},
      [&](const ImagePair& pair, FeatureMatchSpan matches) {
        read_order.push_back(ImagePairToPairId(pair.image_id1, pair.image_id2));
        num_mismatches +=
            matches.size() != 15 + (pair.image_id1 * pair.image_id2) % 7;
        for (size_t k = 0; k < matches.size(); ++k) {
          num_mismatches += matches[k].idx1 != k || matches[k].idx2 != k + 1;
        }
      });
  EXPECT_EQ(read_order, visited);
  EXPECT_EQ(num_mismatches, 0u);
  num_calls = 0;
  size_t num_read = 0;
  EXPECT_THROW(db.ForEachInlierMatches(
                   requested, [&](const ImagePair&, FeatureMatchSpan) {
                     ++num_calls;
                   },
                   [&](const ImagePair&, FeatureMatchSpan) {
                     if (++num_read == 3000) throw Error("stop reading");
                   }),
               Error);
  EXPECT_EQ(num_read, 3000u);
  EXPECT_LT(num_calls, 3000u);
  // At the first pair, while the reader is still filling its queue.
  num_calls = 0;
  EXPECT_THROW(db.ForEachInlierMatches(
                   requested,
                   [&](const ImagePair&, FeatureMatchSpan) {
                     ++num_calls;
                     throw Error("stop at once");
                   }),
               Error);
  EXPECT_EQ(num_calls, 1u);
  EXPECT_EQ(db.ReadInlierMatches(3, 6).size(), 15u + 18 % 7);
}

TEST(Database, SimplePinholeCameraIsCentred) {
  const DatabaseCamera c = SimplePinholeCamera(3, 1067, 800, 900);
  EXPECT_EQ(c.camera_id, 3u);
  EXPECT_EQ(c.model_id, 0);  // SIMPLE_PINHOLE
  EXPECT_EQ(c.width, 1067u);
  EXPECT_EQ(c.height, 800u);
  EXPECT_EQ(c.params, (std::vector<double>{900, 533.5, 400}));
}

TEST(Database, PairIdsMatchColmap) {
  EXPECT_EQ(ImagePairToPairId(1, 2), 2147483649u);
  EXPECT_EQ(ImagePairToPairId(2, 1), 2147483649u);
  EXPECT_EQ(PairIdToImagePair(2147483651u), ImagePair(1, 4));
}

TEST(Database, RejectsBadFiles) {
  TempDir tmp;
  EXPECT_THROW(Database(tmp / "missing.db"), Error);
  {
    std::FILE* f = std::fopen((tmp / "text.db").c_str(), "w");
    std::fputs("this is not a database at all, just some text\n", f);
    std::fclose(f);
  }
  EXPECT_THROW(Database(tmp / "text.db"), Error);
  sqlite3* db = nullptr;
  sqlite3_open((tmp / "other.db").c_str(), &db);
  sqlite3_exec(db, "CREATE TABLE foo(x INTEGER);", nullptr, nullptr, nullptr);
  sqlite3_close(db);
  try {
    Database d(tmp / "other.db");
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("not a COLMAP database"),
              std::string::npos);
  }
}

TEST(Database, FilteredCopyKeepsOnlyChosenPairsAndLeavesSourceIntact) {
  TempDir tmp;
  const std::string src = tmp / "src.db";
  WriteRandomDatabase(src, 5, 2);
  const uint64_t before = FileFingerprint(src);
  const std::vector<ImagePair> keep = {ImagePair(1, 2), ImagePair(3, 5)};
  FilteredDatabaseOptions options;
  options.copy_matches = true;
  WriteFilteredDatabase(src, tmp / "out.db", keep, options);
  EXPECT_EQ(FileFingerprint(src), before);
  Database out(tmp / "out.db");
  EXPECT_EQ(out.ReadImages().size(), 5u);
  EXPECT_EQ(out.ReadKeypoints(4).rows(), 24);
  EXPECT_EQ(out.ReadDescriptors(4).rows(), 0) << "descriptors not copied";
  const auto pairs = out.ReadVerifiedPairs(1);
  ASSERT_EQ(pairs.size(), 2u);
  EXPECT_EQ(pairs[0].pair, ImagePair(1, 2));
  EXPECT_EQ(pairs[1].pair, ImagePair(3, 5));
  EXPECT_EQ(out.ReadMatches(3, 5).size(),
            Database(src).ReadMatches(3, 5).size());
  EXPECT_TRUE(out.ReadMatches(1, 3).empty());
}

// Other COLMAP versions add or drop columns (the images' priors) and tools
// leave out the tables colmap mapper does not read: the filtered copy has
// COLMAP 3.8's schema with the columns the source has.
TEST(Database, FilteredCopyOfOtherSchemas) {
  TempDir tmp;
  const std::string src = tmp / "src.db";
  WriteRandomDatabase(src, 4, 5);
  sqlite3* db = nullptr;
  ASSERT_EQ(sqlite3_open(src.c_str(), &db), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(db,
                         "ALTER TABLE images ADD COLUMN extra TEXT; "
                         "ALTER TABLE images DROP COLUMN prior_qw; "
                         "DROP TABLE descriptors; DROP TABLE matches;",
                         nullptr, nullptr, nullptr),
            SQLITE_OK)
      << sqlite3_errmsg(db);
  sqlite3_close(db);
  FilteredDatabaseOptions options;
  options.copy_descriptors = true;
  options.copy_matches = true;
  WriteFilteredDatabase(src, tmp / "out.db", {ImagePair(1, 3)}, options);
  Database out(tmp / "out.db");
  EXPECT_EQ(out.ReadImages().size(), 4u);
  EXPECT_EQ(out.ReadImages()[2].name, "img3.jpg");
  EXPECT_EQ(out.ReadVerifiedPairs(1).size(), 1u);
  EXPECT_EQ(out.ReadKeypoints(2).rows(), 22);
  // Without a descriptors table an image has none (found by the database
  // fuzzer: the validator accepts such a database).
  Database source(src);
  EXPECT_EQ(source.ReadDescriptors(2).rows(), 0);
  EXPECT_EQ(source.ReadKeypoints(2).rows(), 22);
}

// COLMAP writes its databases in WAL mode. Reading one must leave nothing
// beside it (no -shm or -wal file), so that read-only folders work and input
// folders stay as they were; a pending log must still be read.
TEST(Database, ReadsWalDatabasesWithoutTouchingTheirFolder) {
  TempDir tmp;
  const std::string path = tmp / "wal.db";
  WriteRandomDatabase(path, 5, 3);
  sqlite3* writer = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &writer), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(writer, "PRAGMA journal_mode=WAL;", nullptr, nullptr,
                         nullptr),
            SQLITE_OK);
  ASSERT_EQ(sqlite3_close(writer), SQLITE_OK);
  ASSERT_FALSE(std::filesystem::exists(path + "-wal"));
  const uint64_t before = FileFingerprint(path);
  {
    Database db(path);
    EXPECT_EQ(db.ReadImages().size(), 5u);
    EXPECT_EQ(db.ReadVerifiedPairs(1).size(), 10u);
    WriteFilteredDatabase(path, tmp / "out.db", {ImagePair(1, 2)});
    EXPECT_FALSE(std::filesystem::exists(path + "-wal"));
    EXPECT_FALSE(std::filesystem::exists(path + "-shm"));
  }
  EXPECT_EQ(FileFingerprint(path), before);
  EXPECT_EQ(Database(tmp / "out.db").ReadVerifiedPairs(1).size(), 1u);

  // A writer that has not checkpointed yet: its log holds a new image.
  ASSERT_EQ(sqlite3_open(path.c_str(), &writer), SQLITE_OK);
  ASSERT_EQ(sqlite3_exec(writer,
                         "PRAGMA wal_autocheckpoint=0; INSERT INTO images "
                         "(image_id, name, camera_id) VALUES (6, 'new.jpg', "
                         "1);",
                         nullptr, nullptr, nullptr),
            SQLITE_OK);
  ASSERT_TRUE(std::filesystem::exists(path + "-wal"));
  EXPECT_EQ(Database(path).ReadImages().size(), 6u);
  sqlite3_close(writer);
}

TEST(Database, SchemaMatchesColmapsOwn) {
  if (!ColmapAvailable()) GTEST_SKIP() << "colmap is not installed";
  TempDir tmp;
  ASSERT_EQ(RunShell("colmap database_creator --database_path " +
                     (tmp / "colmap.db")),
            0);
  WriteRandomDatabase(tmp / "ours.db", 2, 3);
  EXPECT_EQ(SchemaOf(tmp / "ours.db"), SchemaOf(tmp / "colmap.db"));
}

TEST(Database, ColmapReadsWhatWeWrite) {
  if (!ColmapAvailable()) GTEST_SKIP() << "colmap is not installed";
  TempDir tmp;
  WriteRandomDatabase(tmp / "a.db", 4, 4);
  ASSERT_EQ(RunShell("colmap database_creator --database_path " +
                     (tmp / "empty.db")),
            0);
  // COLMAP reads our database and writes its own copy.
  ASSERT_EQ(RunShell("colmap database_merger --database_path1 " +
                     (tmp / "a.db") + " --database_path2 " +
                     (tmp / "empty.db") + " --merged_database_path " +
                     (tmp / "merged.db")),
            0);
  Database ours(tmp / "a.db");
  Database theirs(tmp / "merged.db");
  ASSERT_EQ(theirs.ReadImages().size(), 4u);
  EXPECT_EQ(theirs.ReadCameras()[0].params, ours.ReadCameras()[0].params);
  EXPECT_EQ(theirs.NumVerifiedPairs(), ours.NumVerifiedPairs());
  for (const DatabaseImage& im : theirs.ReadImages()) {
    EXPECT_EQ(theirs.ReadKeypoints(im.image_id),
              ours.ReadKeypoints(im.image_id));
  }
  const TwoViewGeometry a = ours.ReadTwoViewGeometry(1, 3);
  const TwoViewGeometry b = theirs.ReadTwoViewGeometry(1, 3);
  EXPECT_EQ(a.inlier_matches.size(), b.inlier_matches.size());
  EXPECT_TRUE(a.F.isApprox(b.F));
}

TEST(Database, ReadsTheSharedCupDatabase) {
  const std::string path = SharedDataPath("yan2017/cup", "database.db");
  if (path.empty()) {
    GTEST_SKIP() << "shared data not found (set HISFM_DATA_DIR): "
                 << SharedDataDir();
  }
  const uint64_t before = FileFingerprint(path);
  {
    Database db(path);
    EXPECT_EQ(db.ReadImages().size(), 64u);
    EXPECT_EQ(db.ReadCameras().size(), 1u);
    EXPECT_EQ(db.NumVerifiedPairs(15), 2016u);
    EXPECT_GT(db.ReadKeypoints(1).rows(), 1000);
  }
  EXPECT_EQ(FileFingerprint(path), before);
}

}  // namespace
}  // namespace hisfm
