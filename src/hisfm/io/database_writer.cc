#include "hisfm/io/database_writer.h"

#include <sqlite3.h>

#include <filesystem>

#include "hisfm/io/sqlite_util.h"
#include "hisfm/util/error.h"

namespace hisfm {
namespace {

void BindMatrix3(sqlite3_stmt* stmt, int col, const Eigen::Matrix3d& m) {
  double v[9];
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) v[3 * r + c] = m(r, c);
  sqlite3_bind_blob(stmt, col, v, sizeof(v), SQLITE_TRANSIENT);
}

std::vector<uint32_t> FlattenMatches(const std::vector<FeatureMatch>& m) {
  std::vector<uint32_t> v(2 * m.size());
  for (size_t i = 0; i < m.size(); ++i) {
    v[2 * i] = m[i].idx1;
    v[2 * i + 1] = m[i].idx2;
  }
  return v;
}

}  // namespace

DatabaseWriter::DatabaseWriter(const std::string& path) : path_(path) {
  ThrowUnless(!std::filesystem::exists(path),
              StrCat("database already exists: ", path));
  if (sqlite3_open_v2(path.c_str(), &db_,
                      SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE,
                      nullptr) != SQLITE_OK) {
    sqlite3_close(db_);
    db_ = nullptr;
    throw Error(StrCat("cannot create database ", path));
  }
  for (const std::string& sql : ColmapSchemaStatements()) SqliteExec(db_, sql);
  SqliteExec(db_, "BEGIN;");
}

DatabaseWriter::~DatabaseWriter() {
  try {
    Close();
  } catch (...) {
  }
}

void DatabaseWriter::Close() {
  if (!db_) return;
  SqliteExec(db_, "COMMIT;");
  sqlite3_close(db_);
  db_ = nullptr;
}

void DatabaseWriter::WriteCamera(const DatabaseCamera& camera) {
  ThrowUnless(db_ != nullptr, "database writer is closed");
  SqliteStatement stmt(db_,
                       "INSERT INTO cameras(camera_id, model, width, height, "
                       "params, prior_focal_length) VALUES (?, ?, ?, ?, ?, ?)");
  sqlite3_bind_int64(stmt.get(), 1, camera.camera_id);
  sqlite3_bind_int(stmt.get(), 2, camera.model_id);
  sqlite3_bind_int64(stmt.get(), 3, camera.width);
  sqlite3_bind_int64(stmt.get(), 4, camera.height);
  sqlite3_bind_blob(stmt.get(), 5, camera.params.data(),
                    camera.params.size() * sizeof(double), SQLITE_TRANSIENT);
  sqlite3_bind_int(stmt.get(), 6, camera.prior_focal_length ? 1 : 0);
  stmt.Step();
}

void DatabaseWriter::WriteImage(const DatabaseImage& image) {
  ThrowUnless(db_ != nullptr, "database writer is closed");
  SqliteStatement stmt(
      db_, "INSERT INTO images(image_id, name, camera_id) VALUES (?, ?, ?)");
  sqlite3_bind_int64(stmt.get(), 1, image.image_id);
  sqlite3_bind_text(stmt.get(), 2, image.name.c_str(), -1, SQLITE_TRANSIENT);
  sqlite3_bind_int64(stmt.get(), 3, image.camera_id);
  stmt.Step();
}

void DatabaseWriter::WriteKeypoints(ImageId image_id,
                                    const Keypoints& keypoints) {
  ThrowUnless(db_ != nullptr, "database writer is closed");
  SqliteStatement stmt(
      db_, "INSERT INTO keypoints(image_id, rows, cols, data) VALUES (?,?,?,?)");
  sqlite3_bind_int64(stmt.get(), 1, image_id);
  sqlite3_bind_int64(stmt.get(), 2, keypoints.rows());
  sqlite3_bind_int64(stmt.get(), 3, 2);
  sqlite3_bind_blob(stmt.get(), 4, keypoints.data(),
                    keypoints.size() * sizeof(float), SQLITE_TRANSIENT);
  stmt.Step();
}

void DatabaseWriter::WriteDescriptors(ImageId image_id,
                                      const Descriptors& descriptors) {
  ThrowUnless(db_ != nullptr, "database writer is closed");
  SqliteStatement stmt(
      db_,
      "INSERT INTO descriptors(image_id, rows, cols, data) VALUES (?,?,?,?)");
  sqlite3_bind_int64(stmt.get(), 1, image_id);
  sqlite3_bind_int64(stmt.get(), 2, descriptors.rows());
  sqlite3_bind_int64(stmt.get(), 3, descriptors.cols());
  sqlite3_bind_blob(stmt.get(), 4, descriptors.data(), descriptors.size(),
                    SQLITE_TRANSIENT);
  stmt.Step();
}

void DatabaseWriter::WriteMatches(const ImagePair& pair,
                                  const std::vector<FeatureMatch>& matches) {
  ThrowUnless(db_ != nullptr, "database writer is closed");
  SqliteStatement stmt(
      db_, "INSERT INTO matches(pair_id, rows, cols, data) VALUES (?,?,?,?)");
  const std::vector<uint32_t> v = FlattenMatches(matches);
  sqlite3_bind_int64(stmt.get(), 1,
                     ImagePairToPairId(pair.image_id1, pair.image_id2));
  sqlite3_bind_int64(stmt.get(), 2, matches.size());
  sqlite3_bind_int64(stmt.get(), 3, 2);
  sqlite3_bind_blob(stmt.get(), 4, v.data(), v.size() * sizeof(uint32_t),
                    SQLITE_TRANSIENT);
  stmt.Step();
}

void DatabaseWriter::WriteTwoViewGeometry(const TwoViewGeometry& g) {
  ThrowUnless(db_ != nullptr, "database writer is closed");
  SqliteStatement stmt(db_,
                       "INSERT INTO two_view_geometries(pair_id, rows, cols, "
                       "data, config, F, E, H, qvec, tvec) VALUES "
                       "(?,?,?,?,?,?,?,?,?,?)");
  const std::vector<uint32_t> v = FlattenMatches(g.inlier_matches);
  sqlite3_bind_int64(stmt.get(), 1,
                     ImagePairToPairId(g.pair.image_id1, g.pair.image_id2));
  sqlite3_bind_int64(stmt.get(), 2, g.inlier_matches.size());
  sqlite3_bind_int64(stmt.get(), 3, 2);
  sqlite3_bind_blob(stmt.get(), 4, v.data(), v.size() * sizeof(uint32_t),
                    SQLITE_TRANSIENT);
  sqlite3_bind_int(stmt.get(), 5, g.config);
  BindMatrix3(stmt.get(), 6, g.F);
  BindMatrix3(stmt.get(), 7, g.E);
  BindMatrix3(stmt.get(), 8, g.H);
  sqlite3_bind_blob(stmt.get(), 9, g.qvec.data(), 4 * sizeof(double),
                    SQLITE_TRANSIENT);
  sqlite3_bind_blob(stmt.get(), 10, g.tvec.data(), 3 * sizeof(double),
                    SQLITE_TRANSIENT);
  stmt.Step();
}

}  // namespace hisfm
