// libFuzzer target: COLMAP databases built row by row from the input, with
// the values that break readers (huge or negative row counts, wrong column
// counts, short blobs, NaN and infinity, pair ids of missing or equal images,
// wrong SQL types, duplicate names, tables without COLMAP's keys), then
// validated and read (fuzz_checks.h).
#include <sqlite3.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <string>
#include <vector>

#include "fuzz_checks.h"
#include "fuzz_input.h"
#include "hisfm/io/database.h"
#include "hisfm/io/model.h"
#include "hisfm/util/types.h"

namespace hisfm {
namespace fuzz {
namespace {

constexpr int64_t kMax32 = 2147483647;
constexpr int64_t kMax64 = std::numeric_limits<int64_t>::max();
constexpr int64_t kMin64 = std::numeric_limits<int64_t>::min();

// Schema variants (bits of the first byte).
constexpr int kLooseImages = 1;       // No UNIQUE names, no id CHECK.
constexpr int kUnkeyedPairs = 2;      // pair_id not the INTEGER PRIMARY KEY.
constexpr int kNoOptionalTables = 4;  // No descriptors, no matches.

std::string Schema(int variant) {
  std::string sql;
  for (std::string statement : ColmapSchemaStatements()) {
    const bool optional =
        statement.find(" descriptors ") != std::string::npos ||
        statement.find(" matches ") != std::string::npos;
    if (optional && (variant & kNoOptionalTables)) continue;
    if (variant & kLooseImages) {
      if (statement.find("INDEX") != std::string::npos) continue;
      const size_t unique = statement.find("NOT NULL UNIQUE");
      if (unique != std::string::npos)
        statement.replace(unique, 15, "NOT NULL");
      const size_t check = statement.find("CONSTRAINT image_id_check");
      if (check != std::string::npos) {
        const size_t end = statement.find("),", check);
        statement.erase(check, end + 2 - check);
      }
    }
    if ((variant & kUnkeyedPairs) &&
        statement.find("pair_id  INTEGER  PRIMARY KEY") != std::string::npos) {
      const size_t key = statement.find("PRIMARY KEY");
      statement.replace(key, 11, "");
    }
    sql += statement;
  }
  return sql;
}

int64_t SmallId(FuzzInput& in) {
  return in.Pick({1, 2, 3, 4, 0, 5, kMax32 - 1, kMax32, -1});
}

float FloatValue(FuzzInput& in) {
  switch (in.Below(8)) {
    case 0:
      return std::numeric_limits<float>::quiet_NaN();
    case 1:
      return std::numeric_limits<float>::infinity();
    case 2:
      return -std::numeric_limits<float>::infinity();
    case 3: {
      const uint32_t bits = static_cast<uint32_t>(in.Word());
      float value;
      std::memcpy(&value, &bits, 4);
      return value;
    }
    default:
      return static_cast<float>(in.Byte()) * 4.0f + 0.5f;
  }
}

double DoubleValue(FuzzInput& in) {
  switch (in.Below(8)) {
    case 0:
      return std::numeric_limits<double>::quiet_NaN();
    case 1:
      return std::numeric_limits<double>::infinity();
    case 2:
      return 0.0;
    case 3: {
      const uint64_t bits = in.Word();
      double value;
      std::memcpy(&value, &bits, 8);
      return value;
    }
    default:
      return static_cast<double>(in.Byte()) + 1.0;
  }
}

// A blob of `n` values from `value`, or (sometimes) random bytes.
template <typename T, typename Value>
std::string Blob(FuzzInput& in, int64_t n, Value&& value) {
  if (n < 0 || n > 4096 || in.Below(8) == 0) return in.Bytes(255);
  std::string out(static_cast<size_t>(n) * sizeof(T), '\0');
  for (int64_t k = 0; k < n; ++k) {
    const T v = value();
    std::memcpy(&out[k * sizeof(T)], &v, sizeof(T));
  }
  return out;
}

// Binds an integer, or now and then a value of another SQL type.
void BindInt(FuzzInput& in, sqlite3_stmt* stmt, int col, int64_t value) {
  switch (in.Below(16)) {
    case 0:
      sqlite3_bind_null(stmt, col);
      return;
    case 1:
      sqlite3_bind_text(stmt, col, std::to_string(value).c_str(), -1,
                        SQLITE_TRANSIENT);
      return;
    case 2:
      sqlite3_bind_double(stmt, col, static_cast<double>(value) + 0.5);
      return;
    default:
      sqlite3_bind_int64(stmt, col, value);
  }
}

void BindBlob(FuzzInput& in, sqlite3_stmt* stmt, int col,
              const std::string& blob) {
  switch (in.Below(16)) {
    case 0:
      sqlite3_bind_null(stmt, col);
      return;
    case 1:
      sqlite3_bind_text(stmt, col, blob.data(), static_cast<int>(blob.size()),
                        SQLITE_TRANSIENT);
      return;
    default:
      sqlite3_bind_blob(stmt, col, blob.data(), static_cast<int>(blob.size()),
                        SQLITE_TRANSIENT);
  }
}

int64_t PairId(FuzzInput& in) {
  const int64_t a = SmallId(in), b = SmallId(in);
  switch (in.Below(4)) {
    case 0:
      return in.Pick({0, -5, kMax64, kMin64, kMax32 * kMax32});
    case 1:  // Possibly swapped or equal; wraps around for huge ids.
      return static_cast<int64_t>(static_cast<uint64_t>(kMax32) * a + b);
    default:
      return static_cast<int64_t>(static_cast<uint64_t>(kMax32) *
                                      std::min(a, b) +
                                  std::max(a, b));
  }
}

// Adds one row to one table; failed inserts (constraints) are ignored.
void AddRow(FuzzInput& in, sqlite3* db) {
  const int table = in.Below(6);
  static const char* kSql[] = {
      "INSERT OR REPLACE INTO cameras VALUES (?, ?, ?, ?, ?, ?)",
      "INSERT OR REPLACE INTO images (image_id, name, camera_id) VALUES "
      "(?, ?, ?)",
      "INSERT OR REPLACE INTO keypoints VALUES (?, ?, ?, ?)",
      "INSERT OR REPLACE INTO descriptors VALUES (?, ?, ?, ?)",
      "INSERT OR REPLACE INTO matches VALUES (?, ?, ?, ?)",
      "INSERT OR REPLACE INTO two_view_geometries VALUES "
      "(?, ?, ?, ?, ?, ?, ?, ?, ?, ?)"};
  sqlite3_stmt* stmt = nullptr;
  if (sqlite3_prepare_v2(db, kSql[table], -1, &stmt, nullptr) != SQLITE_OK) {
    return;  // A table this schema variant lacks.
  }
  switch (table) {
    case 0: {
      BindInt(in, stmt, 1, in.Pick({1, 2, 0, -1}));
      const int64_t model = in.Pick({0, 1, 2, 3, 4, 6, 10, 11, -1});
      BindInt(in, stmt, 2, model);
      BindInt(in, stmt, 3, in.Pick({640, 1, 0, -640, kMax64}));
      BindInt(in, stmt, 4, in.Pick({480, 1, 0, -480, kMax64}));
      const int num_params = model >= 0 && model <= 10
                                 ? CameraModelNumParams(static_cast<int>(model))
                                 : 3;
      const int64_t n = in.Bool() ? num_params : in.Pick({0, 1, 3, 4, 12});
      BindBlob(in, stmt, 5,
               Blob<double>(in, n, [&] { return DoubleValue(in); }));
      BindInt(in, stmt, 6, in.Below(2));
      break;
    }
    case 1: {
      BindInt(in, stmt, 1, SmallId(in));
      static const char* kNames[] = {"a.jpg",  "b.jpg", "c.jpg", "d.jpg",
                                     "a.jpg ", "a\nb",  "",      "e.jpg"};
      const int k = in.Below(9);
      const std::string name = k < 8 ? kNames[k] : in.Bytes(12);
      if (in.Below(16) == 0) {
        sqlite3_bind_blob(stmt, 2, name.data(), static_cast<int>(name.size()),
                          SQLITE_TRANSIENT);
      } else {
        sqlite3_bind_text(stmt, 2, name.data(), static_cast<int>(name.size()),
                          SQLITE_TRANSIENT);
      }
      BindInt(in, stmt, 3, in.Pick({1, 2, 7}));
      break;
    }
    case 2:
    case 3: {
      const bool keypoints = table == 2;
      BindInt(in, stmt, 1, SmallId(in));
      const int64_t rows = in.Pick({3, 5, 0, 1, 8, kMax32, kMax64, -1, -3});
      const int64_t cols =
          keypoints ? in.Pick({2, 4, 6, 3, 0, 128}) : in.Pick({128, 64, 0, 2});
      BindInt(in, stmt, 2, rows);
      BindInt(in, stmt, 3, cols);
      const int64_t n = rows >= 0 && rows < 4096 && cols >= 0 && cols <= 128
                            ? rows * cols
                            : -1;
      const std::string blob =
          keypoints ? Blob<float>(in, in.Below(4) == 0 ? n - 1 : n,
                                  [&] { return FloatValue(in); })
                    : Blob<uint8_t>(in, n, [&] { return in.Byte(); });
      BindBlob(in, stmt, 4, blob);
      break;
    }
    default: {
      const bool geometry = table == 5;
      BindInt(in, stmt, 1, PairId(in));
      const int64_t rows = in.Pick({2, 4, 0, 1, 7, kMax32, kMax64, -2});
      const int64_t cols = in.Pick({2, 3, 0, 1});
      BindInt(in, stmt, 2, rows);
      BindInt(in, stmt, 3, cols);
      const int64_t n = rows >= 0 && rows < 2048 ? rows * 2 : -1;
      BindBlob(in, stmt, 4,
               Blob<uint32_t>(in, in.Below(4) == 0 ? n + 1 : n, [&] {
                 return static_cast<uint32_t>(
                     in.Pick({0, 1, 2, 3, 4, 7, kMax32, 4294967295LL}));
               }));
      if (geometry) {
        BindInt(in, stmt, 5, in.Pick({2, 3, 0, 1, 4, 5, 6, 7, 8, 9, 99, -1}));
        const int sizes[] = {9, 9, 9, 4, 3};
        for (int k = 0; k < 5; ++k) {
          const int64_t count = in.Below(6) == 0 ? in.Below(12) : sizes[k];
          if (in.Below(6) == 0) {
            sqlite3_bind_null(stmt, 6 + k);
          } else {
            BindBlob(in, stmt, 6 + k,
                     Blob<double>(in, count, [&] { return DoubleValue(in); }));
          }
        }
      }
    }
  }
  sqlite3_step(stmt);
  sqlite3_finalize(stmt);
}

}  // namespace
}  // namespace fuzz
}  // namespace hisfm

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace hisfm::fuzz;
  const std::string path = ScratchFolder() + "/built.db";
  std::filesystem::remove(path);
  FuzzInput in(data, size);
  sqlite3* db = nullptr;
  if (sqlite3_open(path.c_str(), &db) != SQLITE_OK) Fail("cannot create");
  sqlite3_exec(db, "PRAGMA journal_mode=OFF; PRAGMA synchronous=OFF; BEGIN;",
               nullptr, nullptr, nullptr);
  if (sqlite3_exec(db, Schema(in.Byte()).c_str(), nullptr, nullptr, nullptr) !=
      SQLITE_OK) {
    Fail(std::string("schema: ") + sqlite3_errmsg(db));
  }
  for (int rows = 0; rows < 64 && !in.empty(); ++rows) AddRow(in, db);
  sqlite3_exec(db, "COMMIT;", nullptr, nullptr, nullptr);
  sqlite3_close(db);
  CheckDatabase(path, /*intact_file=*/true);
  return 0;
}
