#include "hisfm/io/database_validation.h"

#include <sqlite3.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <initializer_list>
#include <limits>
#include <memory>
#include <thread>
#include <unordered_map>
#include <unordered_set>

#include "hisfm/io/database.h"
#include "hisfm/io/model.h"
#include "hisfm/io/sqlite_util.h"
#include "hisfm/util/error.h"
#include "hisfm/util/logging.h"
#include "hisfm/util/timer.h"
#include "hisfm/util/types.h"

namespace hisfm {

std::string FormatDatabaseProblem(const DatabaseProblem& problem) {
  return problem.id.empty()
             ? StrCat(problem.table, ": ", problem.message)
             : StrCat(problem.table, ", ", problem.id, ": ", problem.message);
}

void DatabaseValidationOptions::Check() const {
  HISFM_CHECK_OPTION(max_problems, max_problems >= 0, ">= 0");
}

namespace {

// Keypoint counts of the images (the key set is the images table), or one
// of these: no keypoints row; a row with a problem, or a table that could
// not be read (the count is unknown and not compared with anything).
constexpr int64_t kNoKeypointRow = -2;
constexpr int64_t kBadKeypointRow = -1;
using KeypointCounts = std::unordered_map<int64_t, int64_t>;

constexpr int64_t kMaxCameraId = std::numeric_limits<CameraId>::max() - 1;
// COLMAP's images table: CHECK(image_id >= 0 and image_id < 2147483647).
constexpr int64_t kMaxImageId = static_cast<int64_t>(kMaxNumImages) - 1;
constexpr int kNumTwoViewConfigs = 9;

// A short printable form of any column value, for messages.
std::string ValueText(sqlite3_stmt* stmt, int col) {
  switch (sqlite3_column_type(stmt, col)) {
    case SQLITE_NULL:
      return "NULL";
    case SQLITE_INTEGER:
      return std::to_string(sqlite3_column_int64(stmt, col));
    case SQLITE_FLOAT:
      return StrCat(sqlite3_column_double(stmt, col));
    case SQLITE_BLOB:
      return StrCat("a ", sqlite3_column_bytes(stmt, col), "-byte blob");
    default: {
      const char* text =
          reinterpret_cast<const char*>(sqlite3_column_text(stmt, col));
      std::string s = text ? text : "";
      if (s.size() > 40) s = s.substr(0, 37) + "...";
      // A problem is one line.
      for (char& c : s) {
        if (static_cast<unsigned char>(c) < 0x20 || c == 0x7f) c = '?';
      }
      return "'" + s + "'";
    }
  }
}

bool IsInteger(sqlite3_stmt* stmt, int col) {
  return sqlite3_column_type(stmt, col) == SQLITE_INTEGER;
}

// True if `bytes` is exactly rows * cols * element_bytes (computed without
// overflow for any 64-bit values).
bool SizeMatches(int64_t rows, int64_t cols, int element_bytes, int64_t bytes) {
  if (rows < 0 || cols < 0 || bytes < 0) return false;
  const __int128 expected =
      static_cast<__int128>(rows) * cols * static_cast<__int128>(element_bytes);
  return expected == bytes;
}

std::string SizeMismatch(int64_t rows, int64_t cols, const char* element,
                         int64_t bytes) {
  return StrCat("rows x cols = ", rows, " x ", cols, " ", element,
                " does not match its ", bytes, "-byte data blob");
}

// Index of the first non-finite float of `n` at `data` (unaligned), or -1.
int64_t FirstNonFiniteFloat(const void* data, int64_t n) {
  const unsigned char* bytes = static_cast<const unsigned char*>(data);
  for (int64_t i = 0; i < n; ++i) {
    uint32_t bits;
    std::memcpy(&bits, bytes + 4 * i, 4);
    if ((bits & 0x7f800000u) == 0x7f800000u) return i;
  }
  return -1;
}

// Collects problems up to a limit (0: no limit).
class ProblemList {
 public:
  explicit ProblemList(size_t limit) : limit_(limit) {}
  void Add(const std::string& table, const std::string& id,
           const std::string& message) {
    if (!Full()) problems_.push_back({table, id, message});
  }
  bool Full() const { return limit_ > 0 && problems_.size() >= limit_; }
  size_t size() const { return problems_.size(); }
  std::vector<DatabaseProblem>& problems() { return problems_; }

 private:
  size_t limit_;
  std::vector<DatabaseProblem> problems_;
};

// Runs `scan` and turns an SQLite failure into a problem of the table;
// false after a failure.
template <typename Scan>
bool Guarded(sqlite3* db, const std::string& table, ProblemList* out,
             Scan&& scan) {
  try {
    scan();
    return true;
  } catch (const Error&) {
    out->Add(table, "", StrCat("cannot be read: ", DescribeSqliteError(db)));
    return false;
  }
}

constexpr char kCorruptRow[] =
    "the file is corrupt (a row is not found by its id, or rows are out of "
    "order)";

// True, after reporting the file as corrupt, unless `rowid` follows
// `*previous` (a scan in row-id order).
bool OutOfOrder(int64_t rowid, int64_t* previous, bool* first,
                const char* table, ProblemList* out) {
  const bool out_of_order = !*first && rowid <= *previous;
  *first = false;
  *previous = rowid;
  if (out_of_order) out->Add(table, "", kCorruptRow);
  return out_of_order;
}

std::string RowIdMismatch(const char* column) {
  return StrCat(column,
                " is not the table's INTEGER PRIMARY KEY (not COLMAP's "
                "schema)");
}

// ---------------------------------------------------------------------------
// cameras

void CheckCameras(sqlite3* db, ProblemList* out,
                  std::unordered_set<int64_t>* camera_ids) {
  const char* kTable = "cameras";
  // prior_focal_length is not checked, but read: readers need the column.
  SqliteStatement stmt(db,
                       "SELECT rowid, camera_id, model, width, height, "
                       "params, prior_focal_length FROM cameras ORDER BY "
                       "rowid");
  sqlite3_stmt* s = stmt.get();
  int64_t previous = 0;
  bool first = true;
  while (!out->Full() && stmt.Step()) {
    const int64_t rowid = sqlite3_column_int64(s, 0);
    if (OutOfOrder(rowid, &previous, &first, kTable, out)) break;
    if (!IsInteger(s, 1) || sqlite3_column_int64(s, 1) != rowid) {
      out->Add(kTable, StrCat("camera ", ValueText(s, 1)),
               RowIdMismatch("camera_id"));
      continue;
    }
    const std::string id = StrCat("camera ", rowid);
    if (rowid < 0 || rowid > kMaxCameraId) {
      out->Add(kTable, id, "camera_id is outside COLMAP's range");
      continue;
    }
    camera_ids->insert(rowid);
    const int64_t model = sqlite3_column_int64(s, 2);
    const int num_params = IsInteger(s, 2) && model >= 0 && model <= 1000
                               ? CameraModelNumParams(static_cast<int>(model))
                               : -1;
    if (num_params < 0) {
      out->Add(kTable, id,
               StrCat("model ", ValueText(s, 2),
                      " is not a COLMAP camera model (0-17)"));
    }
    for (int col : {3, 4}) {
      const int64_t size = sqlite3_column_int64(s, col);
      if (!IsInteger(s, col) || size <= 0 ||
          size > std::numeric_limits<int32_t>::max()) {
        out->Add(kTable, id,
                 StrCat(col == 3 ? "width " : "height ", ValueText(s, col),
                        " is not a positive image size"));
      }
    }
    const int type = sqlite3_column_type(s, 5);
    if (type != SQLITE_BLOB && type != SQLITE_NULL) {
      out->Add(kTable, id, "params is not a blob of doubles");
      continue;
    }
    if (num_params < 0) continue;
    const int bytes = sqlite3_column_bytes(s, 5);
    if (bytes != num_params * static_cast<int>(sizeof(double))) {
      out->Add(kTable, id,
               StrCat("params hold ", bytes, " bytes; ",
                      CameraModelIdToName(static_cast<int>(model)), " has ",
                      num_params, " parameters (", num_params * 8, " bytes)"));
      continue;
    }
    std::vector<double> params(num_params);
    std::memcpy(params.data(), sqlite3_column_blob(s, 5), bytes);
    for (int k = 0; k < num_params; ++k) {
      if (!std::isfinite(params[k])) {
        out->Add(kTable, id, StrCat("parameter ", k, " is ", params[k]));
        break;
      }
    }
    for (int k = 0; k < CameraModelNumFocalLengths(static_cast<int>(model));
         ++k) {
      if (!(params[k] > 0)) {
        out->Add(kTable, id,
                 StrCat("focal length ", params[k], " is not positive"));
        break;
      }
    }
  }
}

// ---------------------------------------------------------------------------
// images

// `camera_ids` null: the cameras table could not be read, references to it
// are not checked.
void CheckImages(sqlite3* db, const std::unordered_set<int64_t>* camera_ids,
                 ProblemList* out, KeypointCounts* images) {
  const char* kTable = "images";
  SqliteStatement stmt(db,
                       "SELECT rowid, image_id, name, camera_id FROM images "
                       "ORDER BY rowid");
  sqlite3_stmt* s = stmt.get();
  std::unordered_map<std::string, int64_t> names;
  int64_t previous = 0;
  bool first = true;
  while (!out->Full() && stmt.Step()) {
    const int64_t rowid = sqlite3_column_int64(s, 0);
    if (OutOfOrder(rowid, &previous, &first, kTable, out)) break;
    if (!IsInteger(s, 1) || sqlite3_column_int64(s, 1) != rowid) {
      out->Add(kTable, StrCat("image ", ValueText(s, 1)),
               RowIdMismatch("image_id"));
      continue;
    }
    const std::string id = StrCat("image ", rowid);
    if (rowid < 0 || rowid > kMaxImageId) {
      out->Add(kTable, id, "image_id is outside COLMAP's range [0, 2^31 - 1)");
      continue;
    }
    images->emplace(rowid, kNoKeypointRow);
    if (sqlite3_column_type(s, 2) != SQLITE_TEXT) {
      out->Add(kTable, id, StrCat("name ", ValueText(s, 2), " is not text"));
    } else {
      const char* text =
          reinterpret_cast<const char*>(sqlite3_column_text(s, 2));
      const std::string name(text, sqlite3_column_bytes(s, 2));
      if (name.empty()) {
        out->Add(kTable, id, "name is empty");
      } else if (std::any_of(name.begin(), name.end(), [](char c) {
                   return static_cast<unsigned char>(c) < 0x20 || c == 0x7f;
                 })) {
        out->Add(kTable, id,
                 "name contains a line break or another control character");
      } else if (name.front() == ' ' || name.back() == ' ') {
        // colmap reads image lists line by line, trimmed.
        out->Add(kTable, id, "name begins or ends with a space");
      } else if (const auto [it, inserted] = names.emplace(name, rowid);
                 !inserted) {
        out->Add(kTable, id,
                 StrCat("name '", name, "' is also the name of image ",
                        it->second, " (names must be unique)"));
      }
    }
    if (camera_ids && (!IsInteger(s, 3) ||
                       camera_ids->count(sqlite3_column_int64(s, 3)) == 0)) {
      out->Add(kTable, id,
               StrCat("refers to camera ", ValueText(s, 3),
                      ", which is not in the cameras table"));
    }
  }
}

// ---------------------------------------------------------------------------
// keypoints and descriptors

// Checks the rows, cols and blob of a feature row (columns 1-5 of `s`:
// image_id, rows, cols, typeof(data), length(data)); `allowed_cols` empty
// allows any positive cols. Returns the row count, or -1 after reporting a
// problem.
int64_t CheckFeatureRow(sqlite3_stmt* s, const char* table, const char* id,
                        std::initializer_list<int64_t> allowed_cols,
                        int element_bytes, const char* element,
                        ProblemList* out) {
  const int64_t rows = sqlite3_column_int64(s, 2);
  const int64_t cols = sqlite3_column_int64(s, 3);
  if (!IsInteger(s, 2) || rows < 0) {
    out->Add(table, id, StrCat("rows ", ValueText(s, 2), " is not a count"));
    return -1;
  }
  const bool cols_ok =
      allowed_cols.size() == 0
          ? cols > 0
          : std::find(allowed_cols.begin(), allowed_cols.end(), cols) !=
                allowed_cols.end();
  if (!IsInteger(s, 3) || !cols_ok) {
    if (allowed_cols.size() == 0) {
      out->Add(table, id,
               StrCat("cols ", ValueText(s, 3), " is not a positive count"));
      return -1;
    }
    std::string allowed;
    for (const int64_t c : allowed_cols) {
      allowed += allowed.empty() ? "" : " or ";
      allowed += std::to_string(c);
    }
    out->Add(table, id, StrCat("cols ", ValueText(s, 3), " is not ", allowed));
    return -1;
  }
  const char* type = reinterpret_cast<const char*>(sqlite3_column_text(s, 4));
  const std::string data_type = type ? type : "";
  const int64_t bytes = sqlite3_column_int64(s, 5);
  if (data_type != "blob" && !(data_type == "null" && rows == 0)) {
    out->Add(table, id, StrCat("data is ", data_type, ", not a blob"));
    return -1;
  }
  if (!SizeMatches(rows, cols, element_bytes,
                   data_type == "null" ? 0 : bytes)) {
    out->Add(table, id, SizeMismatch(rows, cols, element, bytes));
    return -1;
  }
  return rows;
}

void CheckKeypoints(sqlite3* db, ProblemList* out, KeypointCounts* images) {
  const char* kTable = "keypoints";
  SqliteStatement stmt(db,
                       "SELECT rowid, image_id, rows, cols, typeof(data), "
                       "length(data) FROM keypoints ORDER BY rowid");
  // Read only once its size is known to match.
  SqliteStatement data(db, "SELECT data FROM keypoints WHERE rowid = ?");
  sqlite3_stmt* s = stmt.get();
  int64_t previous = 0;
  bool first = true;
  while (!out->Full() && stmt.Step()) {
    const int64_t rowid = sqlite3_column_int64(s, 0);
    if (OutOfOrder(rowid, &previous, &first, kTable, out)) break;
    if (!IsInteger(s, 1) || sqlite3_column_int64(s, 1) != rowid) {
      out->Add(kTable, StrCat("image ", ValueText(s, 1)),
               RowIdMismatch("image_id"));
      continue;
    }
    const std::string id = StrCat("image ", rowid);
    const auto image = images->find(rowid);
    if (image == images->end()) {
      out->Add(kTable, id,
               "keypoints of an image that is not in the images "
               "table");
      continue;
    }
    image->second = kBadKeypointRow;
    const int64_t rows =
        CheckFeatureRow(s, kTable, id.c_str(), {2, 4, 6}, 4, "floats", out);
    if (rows < 0) continue;
    const int64_t cols = sqlite3_column_int64(s, 3);
    if (rows > 0) {
      data.Reset();
      sqlite3_bind_int64(data.get(), 1, rowid);
      const void* blob = data.Step() ? sqlite3_column_blob(data.get(), 0)
                                     : nullptr;
      if (!blob || sqlite3_column_bytes(data.get(), 0) != rows * cols * 4) {
        out->Add(kTable, id, kCorruptRow);
        continue;
      }
      const int64_t bad = FirstNonFiniteFloat(blob, rows * cols);
      if (bad >= 0) {
        float value;
        std::memcpy(&value, static_cast<const char*>(blob) + 4 * bad, 4);
        out->Add(kTable, id,
                 StrCat("keypoint ", bad / cols, " has a non-finite value (",
                        value, "); hisfm refuses the database"));
        continue;
      }
    }
    image->second = rows;
  }
}

void CheckDescriptors(sqlite3* db, const KeypointCounts& images,
                      ProblemList* out) {
  const char* kTable = "descriptors";
  // COLMAP 4.0 added the extractor type (0 SIFT: 128 bytes a row; ALIKED
  // stores its float descriptors as bytes, of its own width).
  const bool has_type = SqliteHasColumn(db, kTable, "type");
  SqliteStatement stmt(
      db, StrCat("SELECT rowid, image_id, rows, cols, typeof(data), "
                 "length(data), ",
                 has_type ? "type" : "0", " FROM descriptors ORDER BY rowid"));
  sqlite3_stmt* s = stmt.get();
  int64_t previous = 0;
  bool first = true;
  while (!out->Full() && stmt.Step()) {
    const int64_t rowid = sqlite3_column_int64(s, 0);
    if (OutOfOrder(rowid, &previous, &first, kTable, out)) break;
    if (!IsInteger(s, 1) || sqlite3_column_int64(s, 1) != rowid) {
      out->Add(kTable, StrCat("image ", ValueText(s, 1)),
               RowIdMismatch("image_id"));
      continue;
    }
    const std::string id = StrCat("image ", rowid);
    const auto image = images.find(rowid);
    if (image == images.end()) {
      out->Add(kTable, id,
               "descriptors of an image that is not in the "
               "images table");
      continue;
    }
    const bool sift = sqlite3_column_int64(s, 6) == 0;
    const int64_t rows =
        sift ? CheckFeatureRow(s, kTable, id.c_str(), {128}, 1, "bytes", out)
             : CheckFeatureRow(s, kTable, id.c_str(), {}, 1, "bytes", out);
    if (rows < 0 || image->second == kBadKeypointRow) continue;
    const int64_t num_keypoints = std::max<int64_t>(0, image->second);
    if (rows != num_keypoints) {
      out->Add(kTable, id,
               StrCat(rows, " descriptors for ", num_keypoints, " keypoints"));
    }
  }
}

// ---------------------------------------------------------------------------
// two_view_geometries and matches

struct PairTable {
  const char* name;
  // two_view_geometries: config and the matrices follow the matches.
  bool geometry;
  // "verified pairs" or "matches", for messages.
  const char* what;
};

// Checks the match blob of a row whose pair, rows and cols are valid.
void CheckMatchIndices(const PairTable& table, const std::string& id,
                       const int64_t ids[2], const void* data, int64_t rows,
                       const KeypointCounts& images, ProblemList* out) {
  uint32_t max_idx[2] = {0, 0};
  const unsigned char* bytes = static_cast<const unsigned char*>(data);
  for (int64_t m = 0; m < rows; ++m) {
    uint32_t idx[2];
    std::memcpy(idx, bytes + 8 * m, 8);
    max_idx[0] = std::max(max_idx[0], idx[0]);
    max_idx[1] = std::max(max_idx[1], idx[1]);
  }
  for (int k = 0; k < 2; ++k) {
    const int64_t count = images.at(ids[k]);
    if (count == kBadKeypointRow) continue;  // Reported with the keypoints.
    if (count == kNoKeypointRow) {
      out->Add(
          table.name, id,
          StrCat("image ", ids[k], " has ", table.what, " but no keypoints"));
      continue;
    }
    if (max_idx[k] < count) continue;
    for (int64_t m = 0; m < rows; ++m) {
      uint32_t idx;
      std::memcpy(&idx, bytes + 8 * m + 4 * k, 4);
      if (idx >= count) {
        out->Add(table.name, id,
                 StrCat("match ", m, " names keypoint ", idx, " of image ",
                        ids[k], ", which has ", count, " keypoints"));
        break;
      }
    }
  }
}

// Checks a blob of `n` doubles that may also be empty.
void CheckDoubleBlob(sqlite3_stmt* s, int col, const char* name, int n,
                     const PairTable& table, const std::string& id,
                     ProblemList* out) {
  const int type = sqlite3_column_type(s, col);
  if (type == SQLITE_NULL) return;
  if (type != SQLITE_BLOB) {
    out->Add(table.name, id, StrCat(name, " is not a blob of doubles"));
    return;
  }
  const int bytes = sqlite3_column_bytes(s, col);
  if (bytes == 0) return;
  if (bytes != n * 8) {
    out->Add(table.name, id,
             StrCat(name, " holds ", bytes, " bytes instead of ", n,
                    " doubles (", n * 8, " bytes)"));
    return;
  }
  const unsigned char* data =
      static_cast<const unsigned char*>(sqlite3_column_blob(s, col));
  for (int k = 0; k < n; ++k) {
    double value;
    std::memcpy(&value, data + 8 * k, 8);
    if (!std::isfinite(value)) {
      out->Add(table.name, id,
               StrCat(name, " has a non-finite value (", value, ")"));
      return;
    }
  }
}

// Checks one row of a pair table: columns rowid, pair_id, rows, cols, data
// and, for two_view_geometries, config, F, E, H, qvec, tvec.
void CheckPairRow(sqlite3_stmt* s, const PairTable& table,
                  const KeypointCounts& images, ProblemList* out) {
  const int64_t rowid = sqlite3_column_int64(s, 0);
  if (!IsInteger(s, 1) || sqlite3_column_int64(s, 1) != rowid) {
    out->Add(table.name, StrCat("pair_id ", ValueText(s, 1)),
             RowIdMismatch("pair_id"));
    return;
  }
  const int64_t pair_id = rowid;
  const int64_t max = static_cast<int64_t>(kMaxNumImages);
  const int64_t ids[2] = {pair_id / max, pair_id % max};
  std::string id = StrCat("pair_id ", pair_id);
  bool pair_ok = false;
  if (pair_id < 0 || ids[0] > kMaxImageId) {
    out->Add(table.name, id, "names no two images (out of range)");
  } else if (ids[0] == ids[1]) {
    id = StrCat("images ", ids[0], " and ", ids[1]);
    out->Add(table.name, id, StrCat("pairs image ", ids[0], " with itself"));
  } else if (ids[0] > ids[1]) {
    out->Add(table.name, id,
             StrCat("is not COLMAP's id of images ", ids[1], " and ", ids[0],
                    " (the smaller image id comes first)"));
  } else {
    id = StrCat("images ", ids[0], " and ", ids[1]);
    pair_ok = true;
    for (const int64_t image : ids) {
      if (images.count(image) == 0) {
        out->Add(table.name, id,
                 StrCat("image ", image, " is not in the images table"));
        pair_ok = false;
      }
    }
  }
  const int64_t rows = sqlite3_column_int64(s, 2);
  const int64_t cols = sqlite3_column_int64(s, 3);
  const int type = sqlite3_column_type(s, 4);
  const int64_t bytes = sqlite3_column_bytes(s, 4);
  bool blob_ok = false;
  if (!IsInteger(s, 2) || rows < 0) {
    out->Add(table.name, id,
             StrCat("rows ", ValueText(s, 2), " is not a count"));
  } else if (!IsInteger(s, 3) || !(cols == 2 || (cols == 0 && rows == 0))) {
    out->Add(table.name, id, StrCat("cols ", ValueText(s, 3), " is not 2"));
  } else if (type != SQLITE_BLOB && !(type == SQLITE_NULL && rows == 0)) {
    out->Add(table.name, id, "data is not a blob");
  } else if (!SizeMatches(rows, cols, 4, type == SQLITE_NULL ? 0 : bytes)) {
    out->Add(table.name, id, SizeMismatch(rows, cols, "uint32", bytes));
  } else {
    blob_ok = true;
  }
  if (pair_ok && blob_ok && rows > 0) {
    CheckMatchIndices(table, id, ids, sqlite3_column_blob(s, 4), rows, images,
                      out);
  }
  if (!table.geometry) return;
  const int64_t config = sqlite3_column_int64(s, 5);
  if (!IsInteger(s, 5) || config < 0 || config >= kNumTwoViewConfigs) {
    out->Add(table.name, id,
             StrCat("config ", ValueText(s, 5),
                    " is not a COLMAP two-view configuration (0-8)"));
  }
  CheckDoubleBlob(s, 6, "F", 9, table, id, out);
  CheckDoubleBlob(s, 7, "E", 9, table, id, out);
  CheckDoubleBlob(s, 8, "H", 9, table, id, out);
  CheckDoubleBlob(s, 9, "qvec", 4, table, id, out);
  CheckDoubleBlob(s, 10, "tvec", 3, table, id, out);
}

// Scans a pair table in chunks of row ids, on two read-only connections
// (rows of inliers fill a page each: the scan is I/O and copying). Problems
// are kept in row-id order; with a limit, chunks after the first one that
// reaches it are skipped.
void CheckPairTable(const std::string& path, sqlite3* db,
                    const PairTable& table, const KeypointCounts& images,
                    size_t limit, ProblemList* out) {
  int64_t lo = 0, hi = -1;
  {
    SqliteStatement bounds(
        db, StrCat("SELECT min(rowid), max(rowid) FROM ", table.name));
    if (!bounds.Step() || sqlite3_column_type(bounds.get(), 0) == SQLITE_NULL) {
      return;  // Empty.
    }
    lo = sqlite3_column_int64(bounds.get(), 0);
    hi = sqlite3_column_int64(bounds.get(), 1);
  }
  const __int128 span = static_cast<__int128>(hi) - lo + 1;
  const size_t num_chunks = static_cast<size_t>(std::min<__int128>(64, span));
  auto chunk_begin = [&](size_t c) {
    return static_cast<int64_t>(lo + span * c / num_chunks);
  };
  const std::string sql =
      StrCat("SELECT rowid, pair_id, rows, cols, data",
             table.geometry ? ", config, F, E, H, qvec, tvec" : "", " FROM ",
             table.name, " WHERE rowid >= ? AND rowid <= ? ORDER BY rowid");
  const SqliteConnection second =
      num_chunks > 1 ? OpenReadOnlyConnection(path) : nullptr;
  sqlite3* const connections[2] = {db, second.get()};
  std::vector<ProblemList> chunks(num_chunks, ProblemList(limit));
  std::atomic<size_t> next_chunk(0);
  // Chunks after this one are not needed: it holds `limit` problems.
  std::atomic<size_t> last_needed(num_chunks);
  auto work = [&](int w) {
    sqlite3* connection = connections[w];
    std::unique_ptr<SqliteStatement> stmt;
    for (size_t c = next_chunk++; c < num_chunks && c <= last_needed;
         c = next_chunk++) {
      ProblemList& found = chunks[c];
      Guarded(connection, table.name, &found, [&] {
        if (!stmt) stmt = std::make_unique<SqliteStatement>(connection, sql);
        stmt->Reset();
        sqlite3_bind_int64(stmt->get(), 1, chunk_begin(c));
        sqlite3_bind_int64(stmt->get(), 2,
                           c + 1 == num_chunks ? hi : chunk_begin(c + 1) - 1);
        int64_t previous = 0;
        bool first = true;
        while (!found.Full() && stmt->Step()) {
          if (OutOfOrder(sqlite3_column_int64(stmt->get(), 0), &previous,
                         &first, table.name, &found)) {
            break;
          }
          CheckPairRow(stmt->get(), table, images, &found);
        }
        stmt->Reset();
      });
      if (found.Full()) {
        size_t current = last_needed.load();
        while (c < current && !last_needed.compare_exchange_weak(current, c)) {
        }
      }
    }
  };
  if (second) {
    std::thread helper(work, 1);
    work(0);
    helper.join();
  } else {
    work(0);
  }
  // A file that cannot be read fails every chunk the same way: said once.
  const DatabaseProblem* previous = nullptr;
  for (ProblemList& chunk : chunks) {
    for (const DatabaseProblem& p : chunk.problems()) {
      if (!previous || p.id != previous->id || p.message != previous->message) {
        out->Add(p.table, p.id, p.message);
      }
      previous = &p;
    }
  }
}

// True if `column` is the INTEGER PRIMARY KEY of `table` (an alias of its
// row id), as in COLMAP's schema: the scans rely on it.
bool IsIntegerPrimaryKey(sqlite3* db, const char* table, const char* column) {
  SqliteStatement stmt(db, StrCat("PRAGMA table_info(", table, ")"));
  bool found = false;
  int num_key_columns = 0;
  while (stmt.Step()) {
    const int pk = sqlite3_column_int(stmt.get(), 5);
    num_key_columns += pk > 0;
    const char* name =
        reinterpret_cast<const char*>(sqlite3_column_text(stmt.get(), 1));
    const char* type =
        reinterpret_cast<const char*>(sqlite3_column_text(stmt.get(), 2));
    found |= name && type && pk == 1 && std::string(name) == column &&
             sqlite3_stricmp(type, "INTEGER") == 0;
  }
  return found && num_key_columns == 1;
}

}  // namespace

std::vector<DatabaseProblem> ValidateDatabase(
    const std::string& path, const DatabaseValidationOptions& options) {
  options.Check();
  // Opening through Database gives its one-line errors for files that are
  // no COLMAP database at all.
  { Database probe(path); }
  std::string error;
  const SqliteConnection connection = OpenReadOnlyConnection(path, &error);
  ThrowUnless(connection != nullptr,
              StrCat("cannot open database ", path, ": ", error));
  sqlite3* db = connection.get();
  const size_t limit = static_cast<size_t>(options.max_problems);
  ProblemList out(limit);
  std::unordered_set<int64_t> camera_ids;
  KeypointCounts images;
  // A table whose id column is not its row id is not COLMAP's: said once
  // for the table, which is then not scanned.
  auto keyed = [&](const char* table, const char* column) {
    bool ok = false;
    Guarded(db, table, &out,
            [&] { ok = IsIntegerPrimaryKey(db, table, column); });
    if (!ok && !out.Full()) {
      out.Add(table, "", RowIdMismatch(column));
    }
    return ok;
  };
  {
    // One snapshot for the tables read on this connection.
    SqliteExec(db, "BEGIN;");
    const bool cameras_read =
        keyed("cameras", "camera_id") &&
        Guarded(db, "cameras", &out,
                [&] { CheckCameras(db, &out, &camera_ids); });
    const bool images_read =
        keyed("images", "image_id") &&
        Guarded(db, "images", &out, [&] {
          CheckImages(db, cameras_read ? &camera_ids : nullptr, &out,
                      &images);
        });
    if (!images_read) {
      // Every other table refers to images: its problems would follow
      // from this one.
      sqlite3_exec(db, "COMMIT;", nullptr, nullptr, nullptr);
      return std::move(out.problems());
    }
    const bool keypoints_read =
        keyed("keypoints", "image_id") &&
        Guarded(db, "keypoints", &out,
                [&] { CheckKeypoints(db, &out, &images); });
    if (!keypoints_read) {
      // Keypoint counts unknown: not compared with descriptors and matches.
      for (auto& [image_id, count] : images) {
        if (count == kNoKeypointRow) count = kBadKeypointRow;
      }
    }
    if (SqliteHasTable(db, "descriptors") && keyed("descriptors", "image_id")) {
      Guarded(db, "descriptors", &out,
              [&] { CheckDescriptors(db, images, &out); });
    }
    sqlite3_exec(db, "COMMIT;", nullptr, nullptr, nullptr);
  }
  std::vector<PairTable> tables = {
      {"two_view_geometries", true, "verified pairs"}};
  if (options.check_matches && SqliteHasTable(db, "matches")) {
    tables.push_back({"matches", false, "matches"});
  }
  for (const PairTable& table : tables) {
    if (out.Full()) break;
    if (!keyed(table.name, "pair_id")) continue;
    const size_t remaining = limit == 0 ? 0 : limit - out.size();
    Guarded(db, table.name, &out,
            [&] { CheckPairTable(path, db, table, images, remaining, &out); });
  }

  return std::move(out.problems());
}

void RequireValidDatabase(const std::string& path) {
  DatabaseValidationOptions options;
  options.max_problems = 1;
  Timer timer;
  const std::vector<DatabaseProblem> problems = ValidateDatabase(path, options);
  if (problems.empty()) {
    HISFM_LOG_DEBUG("database {} checked: no problems ({:.2f} s)", path,
                    timer.ElapsedSeconds());
    return;
  }
  throw Error(StrCat("invalid database ", path, ": ",
                     FormatDatabaseProblem(problems[0]),
                     " (hisfm check_database lists every problem)"));
}

}  // namespace hisfm
