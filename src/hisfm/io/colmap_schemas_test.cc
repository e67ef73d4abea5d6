// Databases in the schema of every COLMAP release hisfm knows, built from
// the release's CREATE statements: read, checked and filtered alike, with
// their newer tables (pose priors, rigs and frames) kept.
#include "hisfm/io/colmap_schemas.h"

#include <gtest/gtest.h>

#include <cstring>
#include <set>

#include "hisfm/io/database.h"
#include "hisfm/io/database_validation.h"
#include "hisfm/io/model.h"
#include "hisfm/io/sqlite_util.h"
#include "hisfm/util/test_util.h"

namespace hisfm {
namespace {

using R = ColmapRelease;

template <typename T>
void BindBlob(sqlite3_stmt* stmt, int col, const std::vector<T>& values) {
  if (values.empty()) {
    sqlite3_bind_null(stmt, col);
  } else {
    sqlite3_bind_blob(stmt, col, values.data(),
                      static_cast<int>(values.size() * sizeof(T)),
                      SQLITE_TRANSIENT);
  }
}

// Runs `sql` with the bound values: integers and blobs of doubles.
class Inserter {
 public:
  explicit Inserter(sqlite3* db) : db_(db) {}
  void Run(const std::string& sql,
           const std::vector<std::vector<double>>& blobs,
           const std::vector<int64_t>& ints) {
    SqliteStatement stmt(db_, sql);
    int col = 1;
    for (const int64_t v : ints) sqlite3_bind_int64(stmt.get(), col++, v);
    for (const auto& blob : blobs) BindBlob(stmt.get(), col++, blob);
    stmt.Step();
  }

 private:
  sqlite3* db_;
};

// The camera model this release added last (its id), to check that
// newer models are read.
int NewestCameraModel(R release) {
  if (release >= R::k4_1) return 16;  // EUCM
  if (release >= R::k4_0) return 12;  // SIMPLE_DIVISION
  if (release >= R::k3_11) return 11;  // RAD_TAN_THIN_PRISM_FISHEYE
  return 5;  // OPENCV_FISHEYE
}

// Writes a small database as `release` writes it: two cameras, three images
// with keypoints and descriptors, two verified pairs, and where the schema
// has them a pose prior, a two-camera rig and two frames.
void WriteReleaseDatabase(R release, const std::string& path) {
  sqlite3* raw = nullptr;
  ASSERT_EQ(sqlite3_open(path.c_str(), &raw), SQLITE_OK);
  SqliteConnection db(raw);
  for (const std::string& sql : ColmapSchemaStatements(release)) {
    SqliteExec(db.get(), sql);
  }
  SqliteExec(db.get(), StrCat("PRAGMA user_version = ",
                              ColmapSchemaUserVersion(release), ";"));
  Inserter in(db.get());
  const int newest = NewestCameraModel(release);
  in.Run("INSERT INTO cameras VALUES (?, ?, ?, ?, ?, 0)",
         {{500, 320, 240, 0.01}}, {1, 2, 640, 480});
  // Focal lengths (the first parameters) positive, distortion small.
  std::vector<double> params(CameraModelNumParams(newest), 0.001);
  for (int k = 0; k < CameraModelNumFocalLengths(newest); ++k) params[k] = 480;
  in.Run("INSERT INTO cameras VALUES (?, ?, ?, ?, ?, 0)", {params},
         {2, newest, 640, 480});
  for (int id = 1; id <= 3; ++id) {
    SqliteExec(db.get(),
               StrCat("INSERT INTO images (image_id, name, camera_id) VALUES (",
                      id, ", 'im", id, ".jpg', ", id == 2 ? 2 : 1, ");"));
    std::vector<float> keypoints;
    for (int k = 0; k < 4; ++k) {
      keypoints.insert(keypoints.end(),
                       {10.0f * k + id, 20.0f * k, 1, 0, 0, 1});
    }
    SqliteStatement kp(db.get(),
                       "INSERT INTO keypoints VALUES (?, 4, 6, ?)");
    sqlite3_bind_int64(kp.get(), 1, id);
    BindBlob(kp.get(), 2, keypoints);
    kp.Step();
    // 4.0: SIFT (type 0) for two images, ALIKED (type 2: float32 as bytes,
    // 128 floats a row) for the third.
    const bool aliked = release >= R::k4_0 && id == 3;
    const std::vector<uint8_t> descriptors(4 * (aliked ? 512 : 128), id);
    SqliteStatement d(
        db.get(),
        release >= R::k4_0
            ? StrCat("INSERT INTO descriptors VALUES (?, ", aliked ? 2 : 0,
                     ", 4, ", aliked ? 512 : 128, ", ?)")
            : std::string("INSERT INTO descriptors VALUES (?, 4, 128, ?)"));
    sqlite3_bind_int64(d.get(), 1, id);
    BindBlob(d.get(), 2, descriptors);
    d.Step();
  }
  // 4.0 leaves unknown matrices NULL; earlier releases store zeros.
  const bool nulls = release >= R::k4_0;
  const std::vector<double> F = nulls ? std::vector<double>()
                                      : std::vector<double>(9, 0.0);
  const std::vector<double> q = nulls ? std::vector<double>()
                                      : std::vector<double>{1, 0, 0, 0};
  const std::vector<double> t = nulls ? std::vector<double>()
                                      : std::vector<double>{0, 0, 0};
  for (const ImagePair pair : {ImagePair(1, 2), ImagePair(2, 3)}) {
    const std::vector<uint32_t> matches = {0, 0, 1, 1, 2, 2, 3, 3};
    SqliteStatement g(db.get(),
                      "INSERT INTO two_view_geometries VALUES (?, 4, 2, ?, "
                      "2, ?, ?, ?, ?, ?)");
    sqlite3_bind_int64(g.get(), 1,
                       ImagePairToPairId(pair.image_id1, pair.image_id2));
    BindBlob(g.get(), 2, matches);
    BindBlob(g.get(), 3, F);
    BindBlob(g.get(), 4, F);
    BindBlob(g.get(), 5, F);
    BindBlob(g.get(), 6, q);
    BindBlob(g.get(), 7, t);
    g.Step();
  }
  const std::vector<double> position = {1, 2, 3};
  const std::vector<double> covariance = {1, 0, 0, 0, 1, 0, 0, 0, 1};
  if (release >= R::k4_0) {
    in.Run("INSERT INTO pose_priors VALUES (1, 1, 1, 0, ?, ?, ?, 1)",
           {position, covariance, {0, 1, 0}}, {});
  } else if (release >= R::k3_11) {
    in.Run("INSERT INTO pose_priors VALUES (1, ?, 1, ?)",
           {position, covariance}, {});
  } else if (release >= R::k3_10) {
    in.Run("INSERT INTO pose_priors VALUES (1, ?, 1)", {position}, {});
  }
  if (release >= R::k3_12) {
    SqliteExec(db.get(), "INSERT INTO rigs VALUES (1, 1, 0);");
    in.Run("INSERT INTO rig_sensors VALUES (1, 2, 0, ?)",
           {{1, 0, 0, 0, 0.5, 0, 0}}, {});
    SqliteExec(db.get(),
               "INSERT INTO frames VALUES (1, 1); INSERT INTO frames VALUES "
               "(2, 1); INSERT INTO frame_data VALUES (1, 1, 1, 0); INSERT "
               "INTO frame_data VALUES (1, 2, 2, 0); INSERT INTO frame_data "
               "VALUES (2, 3, 1, 0);");
  }
}

std::string OldestReleaseOfLayout(R release) {
  if (release >= R::k4_0) return "4.0";
  if (release >= R::k3_12) return "3.12";
  if (release >= R::k3_11) return "3.11";
  if (release >= R::k3_10) return "3.10";
  return "3.8";
}

// Names of the tables and indexes of a database, and its user_version.
std::pair<std::set<std::string>, int> Schema(const std::string& path) {
  sqlite3* raw = nullptr;
  sqlite3_open_v2(path.c_str(), &raw, SQLITE_OPEN_READONLY, nullptr);
  SqliteConnection db(raw);
  std::set<std::string> names;
  SqliteStatement stmt(db.get(),
                       "SELECT name FROM sqlite_master WHERE name NOT LIKE "
                       "'sqlite_%'");
  while (stmt.Step()) {
    names.insert(
        reinterpret_cast<const char*>(sqlite3_column_text(stmt.get(), 0)));
  }
  SqliteStatement version(db.get(), "PRAGMA user_version");
  version.Step();
  return {names, sqlite3_column_int(version.get(), 0)};
}

TEST(ColmapSchemas, EveryReleaseIsReadCheckedAndFilteredWithItsTables) {
  for (const R release : AllColmapReleases()) {
    SCOPED_TRACE(ColmapReleaseName(release));
    TempDir tmp;
    const std::string path = tmp / "database.db";
    WriteReleaseDatabase(release, path);
    {
      Database db(path);
      const DatabaseLayout layout = db.Layout();
      EXPECT_EQ(layout.OldestRelease(), OldestReleaseOfLayout(release));
      EXPECT_EQ(layout.user_version, ColmapSchemaUserVersion(release));
      EXPECT_EQ(layout.image_prior_columns, release <= R::k3_9);
      const std::vector<DatabaseCamera> cameras = db.ReadCameras();
      ASSERT_EQ(cameras.size(), 2u);
      EXPECT_EQ(cameras[1].model_id, NewestCameraModel(release));
      EXPECT_EQ(static_cast<int>(cameras[1].params.size()),
                CameraModelNumParams(NewestCameraModel(release)));
      ASSERT_EQ(db.ReadImages().size(), 3u);
      EXPECT_EQ(db.ReadImages()[2].name, "im3.jpg");
      EXPECT_EQ(db.ReadVerifiedPairs(1).size(), 2u);
      const TwoViewGeometry g = db.ReadTwoViewGeometry(2, 3);
      EXPECT_EQ(g.inlier_matches.size(), 4u);
      EXPECT_EQ(g.config, 2);
      EXPECT_TRUE(g.F.isZero());
      EXPECT_EQ(db.ReadKeypoints(3).rows(), 4);
      EXPECT_FLOAT_EQ(db.ReadKeypoints(3)(1, 0), 13.0f);

      const std::vector<DatabasePosePrior> priors = db.ReadPosePriors();
      ASSERT_EQ(priors.size(), release >= R::k3_10 ? 1u : 0u);
      if (!priors.empty()) {
        EXPECT_EQ(priors[0].image_id, 1u);
        EXPECT_EQ(priors[0].position, Eigen::Vector3d(1, 2, 3));
        EXPECT_EQ(priors[0].coordinate_system, 1);
        EXPECT_EQ(priors[0].position_covariance.allFinite(),
                  release >= R::k3_11);
        EXPECT_EQ(priors[0].gravity.allFinite(), release >= R::k4_0);
      }
      const std::vector<Rig> rigs = db.ReadRigs();
      const std::vector<Frame> frames = db.ReadFrames();
      ASSERT_EQ(rigs.size(), release >= R::k3_12 ? 1u : 0u);
      ASSERT_EQ(frames.size(), release >= R::k3_12 ? 2u : 0u);
      if (!rigs.empty()) {
        EXPECT_EQ(rigs[0].ref_sensor->id, 1u);
        ASSERT_EQ(rigs[0].sensors.size(), 1u);
        EXPECT_EQ(rigs[0].sensors[0].sensor.id, 2u);
        EXPECT_EQ(rigs[0].sensors[0].sensor.type, SensorType::kCamera);
        EXPECT_DOUBLE_EQ(rigs[0].sensors[0].sensor_from_rig->translation.x(),
                         0.5);
        ASSERT_EQ(frames[0].data.size(), 2u);
        EXPECT_EQ(frames[0].data[1].data_id, 2u);
        EXPECT_EQ(frames[1].data[0].sensor.id, 1u);
      }
    }
    std::string problems;
    for (const DatabaseProblem& p : ValidateDatabase(path)) {
      problems += FormatDatabaseProblem(p) + "\n";
    }
    EXPECT_EQ(problems, "");

    // The filtered copy keeps the schema, the user_version and every table
    // but the dropped pair.
    WriteFilteredDatabase(path, tmp / "filtered.db", {ImagePair(1, 2)});
    const auto [source_names, source_version] = Schema(path);
    const auto [copy_names, copy_version] = Schema(tmp / "filtered.db");
    EXPECT_EQ(copy_names, source_names);
    EXPECT_EQ(copy_version, source_version);
    Database copy(tmp / "filtered.db");
    EXPECT_EQ(copy.ReadVerifiedPairs(1).size(), 1u);
    EXPECT_EQ(copy.ReadPosePriors().size(), release >= R::k3_10 ? 1u : 0u);
    EXPECT_EQ(copy.ReadRigs().size(), release >= R::k3_12 ? 1u : 0u);
    EXPECT_EQ(copy.ReadFrames().size(), release >= R::k3_12 ? 2u : 0u);
    EXPECT_EQ(copy.Layout().OldestRelease(), OldestReleaseOfLayout(release));
    EXPECT_TRUE(copy.ReadDescriptors(1).size() == 0);
    EXPECT_TRUE(ValidateDatabase(tmp / "filtered.db").empty());
  }
}

TEST(ColmapSchemas, UserVersions) {
  EXPECT_EQ(ColmapSchemaUserVersion(R::k3_8), 3800);
  EXPECT_EQ(ColmapSchemaUserVersion(R::k3_12), 3900);
  EXPECT_EQ(ColmapSchemaUserVersion(R::k3_13), 3130000);
  EXPECT_EQ(ColmapSchemaUserVersion(R::k4_1), 4010000);
}

}  // namespace
}  // namespace hisfm
