#include "hisfm/io/database.h"

#include <sqlite3.h>

#include <algorithm>
#include <atomic>
#include <condition_variable>
#include <cstring>
#include <deque>
#include <exception>
#include <filesystem>
#include <mutex>
#include <random>
#include <thread>

#include "hisfm/io/sqlite_util.h"
#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"
#include "hisfm/util/parallel.h"

namespace hisfm {
namespace {

template <typename T>
std::vector<T> ReadBlob(sqlite3_stmt* stmt, int col) {
  const void* data = sqlite3_column_blob(stmt, col);
  const int bytes = sqlite3_column_bytes(stmt, col);
  std::vector<T> out(data ? bytes / sizeof(T) : 0);
  if (!out.empty()) std::memcpy(out.data(), data, out.size() * sizeof(T));
  return out;
}

Eigen::Matrix3d ReadMatrix3Blob(sqlite3_stmt* stmt, int col) {
  const std::vector<double> v = ReadBlob<double>(stmt, col);
  Eigen::Matrix3d m = Eigen::Matrix3d::Zero();
  if (v.size() == 9) {
    // Stored row-major.
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 3; ++c) m(r, c) = v[3 * r + c];
  }
  return m;
}

// A row's match blob (rows x 2 uint32: keypoint indices in the pair's two
// images), checked against its row count, not copied. SQLite does not align
// blobs: they are read with memcpy only.
struct MatchesView {
  const void* data = nullptr;
  size_t size = 0;
};

// Appends the matches of `v` to `out`.
void AppendMatches(const MatchesView& v, std::vector<FeatureMatch>* out) {
  const size_t old_size = out->size();
  out->resize(old_size + v.size);
  if (v.size > 0) {
    std::memcpy(out->data() + old_size, v.data, v.size * sizeof(FeatureMatch));
  }
}

MatchesView MatchesOf(sqlite3_stmt* stmt, int rows_col, int data_col) {
  static_assert(sizeof(FeatureMatch) == 2 * sizeof(uint32_t),
                "FeatureMatch must be two packed uint32");
  const sqlite3_int64 rows = sqlite3_column_int64(stmt, rows_col);
  const void* data = sqlite3_column_blob(stmt, data_col);
  const int bytes = sqlite3_column_bytes(stmt, data_col);
  // (Checks on hot paths build their message only when they fail.)
  if (rows < 0 || rows > bytes || (rows > 0 && !data) ||
      static_cast<size_t>(bytes) !=
          static_cast<size_t>(rows) * sizeof(FeatureMatch)) {
    throw Error("database error: corrupt match blob");
  }
  return {data, static_cast<size_t>(rows)};
}

std::vector<FeatureMatch> ReadMatchesBlob(sqlite3_stmt* stmt, int rows_col,
                                          int data_col) {
  std::vector<FeatureMatch> out;
  AppendMatches(MatchesOf(stmt, rows_col, data_col), &out);
  return out;
}

}  // namespace

// Statements prepared once per database and reused (preparing costs about as
// much as a small read).
struct Database::CachedStatements {
  std::unique_ptr<SqliteStatement> geometry;
  std::unique_ptr<SqliteStatement> inliers;
  std::unique_ptr<SqliteStatement> keypoints;

  SqliteStatement& Get(std::unique_ptr<SqliteStatement>& slot, sqlite3* db,
                       const char* sql) {
    if (!slot) slot = std::make_unique<SqliteStatement>(db, sql);
    slot->Reset();
    return *slot;
  }
};

Database::ReadScope::ReadScope(const Database& database)
    : database_(database) {
  database_.BeginRead();
}

Database::ReadScope::~ReadScope() { database_.EndRead(); }

void Database::BeginRead() const {
  if (read_depth_++ == 0) SqliteExec(db_, "BEGIN;");
}

void Database::EndRead() const {
  if (--read_depth_ == 0) {
    // Statements must not hold the transaction open.
    if (statements_->geometry) statements_->geometry->Reset();
    if (statements_->inliers) statements_->inliers->Reset();
    if (statements_->keypoints) statements_->keypoints->Reset();
    sqlite3_exec(db_, "COMMIT;", nullptr, nullptr, nullptr);
  }
}

DatabaseCamera SimplePinholeCamera(CameraId camera_id, uint64_t width,
                                   uint64_t height, double focal_length) {
  DatabaseCamera camera;
  camera.camera_id = camera_id;
  camera.model_id = 0;
  camera.width = width;
  camera.height = height;
  camera.params = {focal_length, 0.5 * width, 0.5 * height};
  return camera;
}

Database::Database(const std::string& path)
    : path_(path), statements_(std::make_unique<CachedStatements>()) {
  CheckFileReadable(path, "database");
  std::string error;
  SqliteConnection connection = OpenReadOnlyConnection(path, &error);
  if (!connection) {
    throw Error(StrCat("cannot open database ", path, ": ", error));
  }
  // No memory-mapped reads: mapped pages count as the process's resident
  // memory (SQLite maps up to 2 GB), and on a warm page cache they save only
  // about a quarter of a full scan of the pair table (0.63 s against 0.82 s
  // for the 1M pairs of a 4 GB database).
  // A file that is not SQLite fails here with "file is not a database".
  size_t num_tables = 0;
  try {
    SqliteStatement stmt(
        connection.get(),
        "SELECT count(*) FROM sqlite_master WHERE type='table' AND name IN "
        "('cameras','images','keypoints','two_view_geometries')");
    if (stmt.Step()) num_tables = sqlite3_column_int(stmt.get(), 0);
  } catch (const Error&) {
    const int code = sqlite3_errcode(connection.get()) & 0xff;
    if (code == SQLITE_NOTADB) {
      throw Error(StrCat("not a COLMAP database (not SQLite): ", path));
    }
    // E.g. a write-ahead log left by a writer, in a folder that is
    // read-only here: SQLite needs to create the log's index beside it.
    // (Not for a corrupt or locked file: the hint would mislead.)
    std::error_code ec;
    const bool has_log =
        std::filesystem::exists(path + "-wal", ec) ||
        std::filesystem::exists(path + "-journal", ec);
    const bool log_hint = has_log && code != SQLITE_CORRUPT &&
                          code != SQLITE_BUSY && code != SQLITE_LOCKED;
    throw Error(StrCat("cannot read database ", path, ": ",
                       DescribeSqliteError(connection.get()),
                       log_hint ? " (a -wal or -journal file is beside it: "
                                  "open it once with sqlite3 or colmap where "
                                  "the folder is writable)"
                                : ""));
  }
  ThrowUnless(num_tables == 4,
              StrCat("not a COLMAP database (missing cameras, images, "
                     "keypoints or two_view_geometries table): ",
                     path));
  db_ = connection.release();
}

Database::~Database() {
  statements_.reset();
  if (db_) sqlite3_close(db_);
}

std::vector<DatabaseCamera> Database::ReadCameras() const {
  SqliteStatement stmt(db_,
                       "SELECT camera_id, model, width, height, params, "
                       "prior_focal_length FROM cameras ORDER BY camera_id");
  std::vector<DatabaseCamera> cameras;
  while (stmt.Step()) {
    DatabaseCamera c;
    c.camera_id = sqlite3_column_int64(stmt.get(), 0);
    c.model_id = sqlite3_column_int(stmt.get(), 1);
    c.width = sqlite3_column_int64(stmt.get(), 2);
    c.height = sqlite3_column_int64(stmt.get(), 3);
    c.params = ReadBlob<double>(stmt.get(), 4);
    c.prior_focal_length = sqlite3_column_int(stmt.get(), 5) != 0;
    cameras.push_back(std::move(c));
  }
  return cameras;
}

std::vector<DatabaseImage> Database::ReadImages() const {
  SqliteStatement stmt(
      db_, "SELECT image_id, name, camera_id FROM images ORDER BY image_id");
  std::vector<DatabaseImage> images;
  while (stmt.Step()) {
    DatabaseImage im;
    im.image_id = sqlite3_column_int64(stmt.get(), 0);
    const unsigned char* name = sqlite3_column_text(stmt.get(), 1);
    im.name = name ? reinterpret_cast<const char*>(name) : "";
    im.camera_id = sqlite3_column_int64(stmt.get(), 2);
    images.push_back(std::move(im));
  }
  return images;
}

namespace {

// A blob of `n` float64 values into `out`; false (and `out` unchanged) if
// the column is NULL or of another size.
template <typename Matrix>
bool ReadDoubles(sqlite3_stmt* stmt, int col, Matrix* out) {
  const std::vector<double> v = ReadBlob<double>(stmt, col);
  if (v.size() != static_cast<size_t>(out->size())) return false;
  // COLMAP writes Eigen's storage order (column-major).
  std::memcpy(out->data(), v.data(), v.size() * sizeof(double));
  return true;
}

}  // namespace

std::string DatabaseLayout::OldestRelease() const {
  if (pose_prior_ids || descriptor_type) return "4.0";
  if (rigs_and_frames) return "3.12";
  if (position_covariance) return "3.11";
  if (pose_priors) return "3.10";
  return "3.8";
}

DatabaseLayout Database::Layout() const {
  DatabaseLayout layout;
  layout.image_prior_columns = SqliteHasColumn(db_, "images", "prior_qw");
  layout.pose_priors = SqliteHasTable(db_, "pose_priors");
  layout.position_covariance =
      SqliteHasColumn(db_, "pose_priors", "position_covariance");
  layout.pose_prior_ids = SqliteHasColumn(db_, "pose_priors", "pose_prior_id");
  layout.rigs_and_frames =
      SqliteHasTable(db_, "rigs") && SqliteHasTable(db_, "rig_sensors") &&
      SqliteHasTable(db_, "frames") && SqliteHasTable(db_, "frame_data");
  layout.descriptor_type = SqliteHasColumn(db_, "descriptors", "type");
  SqliteStatement version(db_, "PRAGMA user_version");
  if (version.Step()) layout.user_version = sqlite3_column_int(version.get(), 0);
  return layout;
}

std::vector<DatabasePosePrior> Database::ReadPosePriors() const {
  const DatabaseLayout layout = Layout();
  std::vector<DatabasePosePrior> priors;
  if (!layout.pose_priors) return priors;
  const std::string covariance =
      layout.position_covariance ? "position_covariance" : "NULL";
  // 4.0: one row per sensor; an image's prior is its camera's (type 0).
  const std::string sql =
      layout.pose_prior_ids
          ? "SELECT corr_data_id, position, position_covariance, "
            "coordinate_system, gravity FROM pose_priors WHERE "
            "corr_sensor_type = 0 ORDER BY corr_data_id"
          : StrCat("SELECT image_id, position, ", covariance,
                   ", coordinate_system, NULL FROM pose_priors ORDER BY "
                   "image_id");
  SqliteStatement stmt(db_, sql);
  while (stmt.Step()) {
    DatabasePosePrior p;
    p.image_id = static_cast<ImageId>(sqlite3_column_int64(stmt.get(), 0));
    ReadDoubles(stmt.get(), 1, &p.position);
    ReadDoubles(stmt.get(), 2, &p.position_covariance);
    p.coordinate_system = sqlite3_column_int(stmt.get(), 3);
    ReadDoubles(stmt.get(), 4, &p.gravity);
    priors.push_back(p);
  }
  return priors;
}

std::vector<Rig> Database::ReadRigs() const {
  std::vector<Rig> rigs;
  if (!Layout().rigs_and_frames) return rigs;
  SqliteStatement stmt(db_,
                       "SELECT rig_id, ref_sensor_id, ref_sensor_type FROM "
                       "rigs ORDER BY rig_id");
  std::unordered_map<uint32_t, size_t> index;
  while (stmt.Step()) {
    Rig rig;
    rig.rig_id = static_cast<uint32_t>(sqlite3_column_int64(stmt.get(), 0));
    rig.ref_sensor = SensorId{
        static_cast<SensorType>(sqlite3_column_int(stmt.get(), 2)),
        static_cast<uint32_t>(sqlite3_column_int64(stmt.get(), 1))};
    index[rig.rig_id] = rigs.size();
    rigs.push_back(std::move(rig));
  }
  SqliteStatement sensors(db_,
                          "SELECT rig_id, sensor_id, sensor_type, "
                          "sensor_from_rig FROM rig_sensors ORDER BY rowid");
  while (sensors.Step()) {
    const auto it = index.find(
        static_cast<uint32_t>(sqlite3_column_int64(sensors.get(), 0)));
    if (it == index.end()) continue;
    RigSensor sensor;
    sensor.sensor = SensorId{
        static_cast<SensorType>(sqlite3_column_int(sensors.get(), 2)),
        static_cast<uint32_t>(sqlite3_column_int64(sensors.get(), 1))};
    Eigen::Matrix<double, 7, 1> pose;
    if (ReadDoubles(sensors.get(), 3, &pose)) {
      sensor.sensor_from_rig = Rigid3d(
          Eigen::Quaterniond(pose(0), pose(1), pose(2), pose(3)),
          pose.tail<3>());
    }
    rigs[it->second].sensors.push_back(sensor);
  }
  return rigs;
}

std::vector<Frame> Database::ReadFrames() const {
  std::vector<Frame> frames;
  if (!Layout().rigs_and_frames) return frames;
  SqliteStatement stmt(db_,
                       "SELECT frame_id, rig_id FROM frames ORDER BY "
                       "frame_id");
  std::unordered_map<uint32_t, size_t> index;
  while (stmt.Step()) {
    Frame frame;
    frame.frame_id = static_cast<uint32_t>(sqlite3_column_int64(stmt.get(), 0));
    frame.rig_id = static_cast<uint32_t>(sqlite3_column_int64(stmt.get(), 1));
    index[frame.frame_id] = frames.size();
    frames.push_back(std::move(frame));
  }
  SqliteStatement data(db_,
                       "SELECT frame_id, data_id, sensor_id, sensor_type FROM "
                       "frame_data ORDER BY rowid");
  while (data.Step()) {
    const auto it = index.find(
        static_cast<uint32_t>(sqlite3_column_int64(data.get(), 0)));
    if (it == index.end()) continue;
    FrameData d;
    d.data_id = static_cast<uint64_t>(sqlite3_column_int64(data.get(), 1));
    d.sensor = SensorId{
        static_cast<SensorType>(sqlite3_column_int(data.get(), 3)),
        static_cast<uint32_t>(sqlite3_column_int64(data.get(), 2))};
    frames[it->second].data.push_back(d);
  }
  return frames;
}

size_t Database::NumVerifiedPairs(uint32_t min_num_inliers) const {
  SqliteStatement stmt(
      db_, "SELECT count(*) FROM two_view_geometries WHERE rows >= ?");
  sqlite3_bind_int64(stmt.get(), 1, std::max<uint32_t>(1, min_num_inliers));
  return stmt.Step() ? sqlite3_column_int64(stmt.get(), 0) : 0;
}

namespace {

// Appends the verified pairs with pair_id in [begin, end) to `out`.
void ReadVerifiedPairRange(sqlite3* db, sqlite3_int64 begin, sqlite3_int64 end,
                           uint32_t min_num_inliers,
                           std::vector<VerifiedPair>* out) {
  SqliteStatement stmt(db,
                       "SELECT pair_id, rows FROM two_view_geometries "
                       "WHERE pair_id >= ? AND pair_id < ? AND rows >= ? "
                       "ORDER BY pair_id");
  sqlite3_bind_int64(stmt.get(), 1, begin);
  sqlite3_bind_int64(stmt.get(), 2, end);
  sqlite3_bind_int64(stmt.get(), 3, std::max<uint32_t>(1, min_num_inliers));
  while (stmt.Step()) {
    VerifiedPair p;
    p.pair = PairIdToImagePair(sqlite3_column_int64(stmt.get(), 0));
    p.num_inliers = sqlite3_column_int(stmt.get(), 1);
    out->push_back(p);
  }
}

}  // namespace

std::vector<VerifiedPair> Database::ReadVerifiedPairs(
    uint32_t min_num_inliers) const {
  // Each row fills most of a page (its inliers are stored inline), so the
  // scan reads the whole table. Two connections share it: the range of first
  // image ids is cut into chunks that they take in turn, so that neither
  // waits for the other however the pairs are spread (an exhaustively
  // matched scene has most pairs at low first ids, a sequence has them
  // evenly).
  // (Two statements: SQLite finds a lone min() or max() of the rowid by one
  // descent of the b-tree, but scans the whole table for both at once.)
  auto end_pair = [&](const char* sql, ImageId* first) {
    SqliteStatement stmt(db_, sql);
    if (!stmt.Step() || sqlite3_column_type(stmt.get(), 0) == SQLITE_NULL) {
      return false;
    }
    *first = PairIdToImagePair(sqlite3_column_int64(stmt.get(), 0)).image_id1;
    return true;
  };
  ImageId first_lo = 0, first_hi = 0;
  if (!end_pair("SELECT min(pair_id) FROM two_view_geometries", &first_lo) ||
      !end_pair("SELECT max(pair_id) FROM two_view_geometries", &first_hi)) {
    return {};
  }
  constexpr size_t kChunksPerConnection = 32;
  const size_t num_firsts = static_cast<size_t>(first_hi - first_lo) + 1;
  const size_t num_chunks = std::min(2 * kChunksPerConnection, num_firsts);
  // Chunk c holds the pairs whose first image id is in
  // [first_lo + c * num_firsts / num_chunks, first_lo + (c + 1) * ...).
  auto chunk_begin = [&](size_t c) {
    return static_cast<sqlite3_int64>(
        kMaxNumImages * (first_lo + c * num_firsts / num_chunks));
  };
  const SqliteConnection second =
      num_chunks > 1 ? OpenReadOnlyConnection(path_) : nullptr;
  sqlite3* const connections[2] = {db_, second.get()};
  std::vector<std::vector<VerifiedPair>> chunks(num_chunks);
  std::atomic<size_t> next_chunk(0);
  ParallelFor(second ? 2 : 1, 2, [&](size_t w) {
    for (size_t c = next_chunk++; c < num_chunks; c = next_chunk++) {
      ReadVerifiedPairRange(connections[w], chunk_begin(c),
                            chunk_begin(c + 1), min_num_inliers, &chunks[c]);
    }
  });
  size_t total = 0;
  for (const auto& chunk : chunks) total += chunk.size();
  std::vector<VerifiedPair> pairs;
  pairs.reserve(total);
  for (const auto& chunk : chunks) {
    pairs.insert(pairs.end(), chunk.begin(), chunk.end());
  }
  return pairs;
}

TwoViewGeometry Database::ReadTwoViewGeometry(ImageId a, ImageId b) const {
  SqliteStatement& stmt = statements_->Get(
      statements_->geometry, db_,
      "SELECT rows, data, config, F, E, H, qvec, tvec FROM "
      "two_view_geometries WHERE pair_id = ?");
  sqlite3_bind_int64(stmt.get(), 1, ImagePairToPairId(a, b));
  if (!stmt.Step()) {
    throw Error(StrCat("no two-view geometry for images ", a, " and ", b,
                       " in ", path_));
  }
  TwoViewGeometry g;
  g.pair = ImagePair(a, b);
  g.inlier_matches = ReadMatchesBlob(stmt.get(), 0, 1);
  g.config = sqlite3_column_int(stmt.get(), 2);
  g.F = ReadMatrix3Blob(stmt.get(), 3);
  g.E = ReadMatrix3Blob(stmt.get(), 4);
  g.H = ReadMatrix3Blob(stmt.get(), 5);
  const std::vector<double> q = ReadBlob<double>(stmt.get(), 6);
  const std::vector<double> t = ReadBlob<double>(stmt.get(), 7);
  if (q.size() == 4) g.qvec = Eigen::Vector4d(q[0], q[1], q[2], q[3]);
  if (t.size() == 3) g.tvec = Eigen::Vector3d(t[0], t[1], t[2]);
  stmt.Reset();
  return g;
}

std::vector<FeatureMatch> Database::ReadInlierMatches(ImageId a,
                                                      ImageId b) const {
  SqliteStatement& stmt = statements_->Get(
      statements_->inliers, db_,
      "SELECT rows, data FROM two_view_geometries WHERE pair_id = ?");
  sqlite3_bind_int64(stmt.get(), 1, ImagePairToPairId(a, b));
  if (!stmt.Step()) {
    throw Error(StrCat("no two-view geometry for images ", a, " and ", b,
                       " in ", path_));
  }
  std::vector<FeatureMatch> out = ReadMatchesBlob(stmt.get(), 0, 1);
  stmt.Reset();
  return out;
}

namespace {

// Scans the inlier matches of the sorted, unique pair ids `ids` through `db`
// and calls `emit(pair_id, matches)` (a MatchesView) for each present one, in
// order. One forward scan from the first wanted pair: rows between wanted
// ones are stepped over without reading their matches, and the scan seeks
// afresh (one b-tree descent) when it would step over more than a few rows
// (a row of inliers fills most of a page, so stepping over a row costs about
// as much as reading it).
template <typename Emit>
void ScanInlierMatches(sqlite3* db, const std::vector<PairId>& ids,
                       Emit&& emit) {
  constexpr int kMaxSkippedRows = 2;
  SqliteStatement stmt(db,
                       "SELECT pair_id, rows, data FROM two_view_geometries "
                       "WHERE pair_id >= ? ORDER BY pair_id");
  const size_t n = ids.size();
  size_t next = 0;  // Next wanted id.
  while (next < n) {
    stmt.Reset();
    sqlite3_bind_int64(stmt.get(), 1, static_cast<sqlite3_int64>(ids[next]));
    int skipped = 0;
    bool table_ended = true;
    while (stmt.Step()) {
      const PairId id =
          static_cast<PairId>(sqlite3_column_int64(stmt.get(), 0));
      while (next < n && ids[next] < id) ++next;  // Absent from the table.
      if (next == n) {
        table_ended = false;
        break;
      }
      if (id != ids[next]) {
        if (++skipped > kMaxSkippedRows) {
          table_ended = false;
          break;
        }
        continue;
      }
      skipped = 0;
      emit(id, MatchesOf(stmt.get(), 1, 2));
      if (++next == n) {
        table_ended = false;
        break;
      }
    }
    // No row at or after the next wanted id: the rest are absent.
    if (table_ended) break;
  }
  stmt.Reset();
}

// Pairs read ahead, handed from the reading thread to the caller's.
struct MatchChunk {
  std::vector<PairId> ids;
  // Matches of ids[k]: [offsets[k], offsets[k + 1]) of `matches`.
  std::vector<size_t> offsets{0};
  std::vector<FeatureMatch> matches;

  // Empties the chunk, keeping its capacity for the next one.
  void Clear() {
    ids.clear();
    offsets.resize(1);
    matches.clear();
  }
};

}  // namespace

void Database::ForEachInlierMatches(
    std::vector<ImagePair> pairs,
    const std::function<void(const ImagePair&, FeatureMatchSpan)>& fn,
    const std::function<void(const ImagePair&, FeatureMatchSpan)>& on_read)
    const {
  std::vector<PairId> ids;
  ids.reserve(pairs.size());
  for (const ImagePair& p : pairs) {
    ids.push_back(ImagePairToPairId(p.image_id1, p.image_id2));
  }
  pairs.clear();
  pairs.shrink_to_fit();
  std::sort(ids.begin(), ids.end());
  ids.erase(std::unique(ids.begin(), ids.end()), ids.end());

  // Many pairs: a second connection reads ahead on its own thread while
  // `fn` runs on this one.
  constexpr size_t kMinPairsToReadAhead = 4096;
  constexpr size_t kChunkPairs = 512;
  constexpr size_t kMaxQueuedChunks = 4;
  const SqliteConnection connection = ids.size() >= kMinPairsToReadAhead
                                          ? OpenReadOnlyConnection(path_)
                                          : nullptr;
  sqlite3* const reader = connection.get();
  if (!reader) {
    // The blobs are not aligned for FeatureMatch: copied first.
    std::vector<FeatureMatch> matches;
    ReadScope scope(*this);
    ScanInlierMatches(db_, ids, [&](PairId id, const MatchesView& v) {
      matches.clear();
      AppendMatches(v, &matches);
      const ImagePair pair = PairIdToImagePair(id);
      if (on_read) on_read(pair, matches);
      fn(pair, matches);
    });
    return;
  }
  std::mutex mutex;
  std::condition_variable changed;
  std::deque<MatchChunk> queue;
  // Chunks the caller has finished with, reused by the reader so that their
  // buffers are allocated once.
  std::vector<MatchChunk> spare;
  bool done = false, stop = false;
  std::exception_ptr error;
  auto produce = [&] {
    MatchChunk chunk;
    auto push = [&] {
      std::unique_lock<std::mutex> lock(mutex);
      changed.wait(lock,
                   [&] { return stop || queue.size() < kMaxQueuedChunks; });
      if (stop) throw Error("reading stopped");
      queue.push_back(std::move(chunk));
      changed.notify_all();
      if (spare.empty()) {
        chunk = MatchChunk();
      } else {
        chunk = std::move(spare.back());
        spare.pop_back();
      }
    };
    try {
      sqlite3_exec(reader, "BEGIN;", nullptr, nullptr, nullptr);
      ScanInlierMatches(reader, ids, [&](PairId id, const MatchesView& v) {
        chunk.ids.push_back(id);
        AppendMatches(v, &chunk.matches);
        chunk.offsets.push_back(chunk.matches.size());
        if (on_read) {
          on_read(PairIdToImagePair(id),
                  FeatureMatchSpan(chunk.matches.data() + chunk.offsets.end()[-2],
                                   v.size));
        }
        if (chunk.ids.size() == kChunkPairs) push();
      });
      if (!chunk.ids.empty()) push();
    } catch (...) {
      std::lock_guard<std::mutex> lock(mutex);
      if (!stop) error = std::current_exception();
    }
    sqlite3_exec(reader, "COMMIT;", nullptr, nullptr, nullptr);
    std::lock_guard<std::mutex> lock(mutex);
    done = true;
    changed.notify_all();
  };
  std::thread producer(produce);
  auto finish = [&] {
    {
      std::lock_guard<std::mutex> lock(mutex);
      stop = true;
      changed.notify_all();
    }
    producer.join();
  };
  try {
    while (true) {
      MatchChunk chunk;
      {
        std::unique_lock<std::mutex> lock(mutex);
        changed.wait(lock,
                     [&] { return done || error || !queue.empty(); });
        // A failed read stops here, without handing on what it queued.
        if (error || queue.empty()) break;
        chunk = std::move(queue.front());
        queue.pop_front();
        changed.notify_all();
      }
      for (size_t k = 0; k < chunk.ids.size(); ++k) {
        fn(PairIdToImagePair(chunk.ids[k]),
           FeatureMatchSpan(chunk.matches.data() + chunk.offsets[k],
                            chunk.offsets[k + 1] - chunk.offsets[k]));
      }
      chunk.Clear();
      std::lock_guard<std::mutex> lock(mutex);
      spare.push_back(std::move(chunk));
    }
  } catch (...) {
    finish();
    throw;
  }
  finish();
  if (error) std::rethrow_exception(error);
}

std::unordered_map<ImageId, size_t> Database::ReadNumKeypoints() const {
  SqliteStatement stmt(db_, "SELECT image_id, rows FROM keypoints");
  std::unordered_map<ImageId, size_t> out;
  while (stmt.Step()) {
    out[static_cast<ImageId>(sqlite3_column_int64(stmt.get(), 0))] =
        static_cast<size_t>(std::max<sqlite3_int64>(
            0, sqlite3_column_int64(stmt.get(), 1)));
  }
  return out;
}

std::vector<FeatureMatch> Database::ReadMatches(ImageId a, ImageId b) const {
  SqliteStatement stmt(db_,
                       "SELECT rows, data FROM matches WHERE pair_id = ?");
  sqlite3_bind_int64(stmt.get(), 1, ImagePairToPairId(a, b));
  if (!stmt.Step()) return {};
  return ReadMatchesBlob(stmt.get(), 0, 1);
}

Keypoints Database::ReadKeypoints(ImageId image_id) const {
  SqliteStatement& stmt =
      statements_->Get(statements_->keypoints, db_,
                       "SELECT rows, cols, data FROM keypoints WHERE "
                       "image_id = ?");
  sqlite3_bind_int64(stmt.get(), 1, image_id);
  if (!stmt.Step()) return Keypoints();
  // Sizes are compared before anything is allocated for the rows.
  const sqlite3_int64 rows = sqlite3_column_int64(stmt.get(), 0);
  const sqlite3_int64 cols = sqlite3_column_int64(stmt.get(), 1);
  const sqlite3_int64 bytes = sqlite3_column_bytes(stmt.get(), 2);
  ThrowUnless(cols >= 2 && cols <= 6 && rows >= 0 && rows <= bytes &&
                  rows * cols * 4 == bytes,
              StrCat("database error: corrupt keypoints of image ", image_id));
  const std::vector<float> v = ReadBlob<float>(stmt.get(), 2);
  Keypoints kp(rows, 2);
  for (sqlite3_int64 i = 0; i < rows; ++i) {
    kp(i, 0) = v[i * cols];
    kp(i, 1) = v[i * cols + 1];
  }
  stmt.Reset();
  return kp;
}

Descriptors Database::ReadDescriptors(ImageId image_id) const {
  // The table is optional (validation accepts a database without it: the
  // mapper needs no descriptors).
  if (!SqliteHasTable(db_, "descriptors")) return Descriptors();
  SqliteStatement stmt(
      db_, "SELECT rows, cols, data FROM descriptors WHERE image_id = ?");
  sqlite3_bind_int64(stmt.get(), 1, image_id);
  if (!stmt.Step()) return Descriptors();
  const sqlite3_int64 rows = sqlite3_column_int64(stmt.get(), 0);
  const sqlite3_int64 cols = sqlite3_column_int64(stmt.get(), 1);
  const sqlite3_int64 bytes = sqlite3_column_bytes(stmt.get(), 2);
  ThrowUnless(rows >= 0 && cols >= 0 &&
                  (rows == 0 ? bytes == 0
                             : cols <= bytes / rows && rows * cols == bytes),
              StrCat("database error: corrupt descriptors of image ",
                     image_id));
  const std::vector<uint8_t> v = ReadBlob<uint8_t>(stmt.get(), 2);
  Descriptors d(rows, cols);
  if (!v.empty()) std::memcpy(d.data(), v.data(), v.size());
  return d;
}

const std::vector<std::string>& ColmapSchemaStatements() {
  static const std::vector<std::string> kStatements = {
      "CREATE TABLE IF NOT EXISTS cameras   (camera_id            INTEGER  "
      "PRIMARY KEY AUTOINCREMENT  NOT NULL,    model                INTEGER  "
      "                           NOT NULL,    width                INTEGER  "
      "                           NOT NULL,    height               INTEGER  "
      "                           NOT NULL,    params               BLOB,    "
      "prior_focal_length   INTEGER                             NOT NULL);",
      "CREATE TABLE IF NOT EXISTS images   (image_id   INTEGER  PRIMARY KEY "
      "AUTOINCREMENT  NOT NULL,    name       TEXT                           "
      "     NOT NULL UNIQUE,    camera_id  INTEGER                           "
      "  NOT NULL,    prior_qw   REAL,    prior_qx   REAL,    prior_qy   "
      "REAL,    prior_qz   REAL,    prior_tx   REAL,    prior_ty   REAL,    "
      "prior_tz   REAL,CONSTRAINT image_id_check CHECK(image_id >= 0 and "
      "image_id < 2147483647),FOREIGN KEY(camera_id) REFERENCES "
      "cameras(camera_id));",
      "CREATE UNIQUE INDEX IF NOT EXISTS index_name ON images(name);",
      "CREATE TABLE IF NOT EXISTS keypoints   (image_id  INTEGER  PRIMARY KEY "
      " NOT NULL,    rows      INTEGER               NOT NULL,    cols      "
      "INTEGER               NOT NULL,    data      BLOB,FOREIGN "
      "KEY(image_id) REFERENCES images(image_id) ON DELETE CASCADE);",
      "CREATE TABLE IF NOT EXISTS descriptors   (image_id  INTEGER  PRIMARY "
      "KEY  NOT NULL,    rows      INTEGER               NOT NULL,    cols   "
      "   INTEGER               NOT NULL,    data      BLOB,FOREIGN "
      "KEY(image_id) REFERENCES images(image_id) ON DELETE CASCADE);",
      "CREATE TABLE IF NOT EXISTS matches   (pair_id  INTEGER  PRIMARY KEY  "
      "NOT NULL,    rows     INTEGER               NOT NULL,    cols     "
      "INTEGER               NOT NULL,    data     BLOB);",
      "CREATE TABLE IF NOT EXISTS two_view_geometries   (pair_id  INTEGER  "
      "PRIMARY KEY  NOT NULL,    rows     INTEGER               NOT NULL,    "
      "cols     INTEGER               NOT NULL,    data     BLOB,    config  "
      " INTEGER               NOT NULL,    F        BLOB,    E        BLOB,  "
      "  H        BLOB,    qvec     BLOB,    tvec     BLOB);",
  };
  return kStatements;
}

void WriteFilteredDatabase(const std::string& source_path,
                           const std::string& output_path,
                           const std::vector<ImagePair>& keep,
                           const FilteredDatabaseOptions& options) {
  options.Check();
  CheckFileReadable(source_path, "database");
  namespace fs = std::filesystem;
  const std::string temp_path =
      output_path + ".tmp-" + std::to_string(std::random_device()());
  std::error_code ec;
  fs::remove(temp_path, ec);
  sqlite3* db = nullptr;
  if (sqlite3_open_v2(temp_path.c_str(), &db,
                      SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE |
                          SQLITE_OPEN_URI,
                      nullptr) != SQLITE_OK) {
    sqlite3_close(db);
    throw Error(StrCat("cannot create database ", output_path));
  }
  try {
    // Attach the source read-only through a URI so it can never be written.
    SqliteExec(db, "ATTACH DATABASE " + SqliteQuote(ReadOnlyUri(source_path)) +
                       " AS src;");
    // The source's tables, then its indexes, as it created them: the colmap
    // that wrote it reads the copy as it reads the source.
    std::vector<std::string> tables;
    {
      std::vector<std::string> schema;
      SqliteStatement stmt(
          db,
          "SELECT type, name, sql FROM src.sqlite_master WHERE sql IS NOT "
          "NULL AND type IN ('table', 'index') AND name NOT LIKE 'sqlite_%' "
          "AND sql NOT LIKE 'CREATE VIRTUAL%' ORDER BY type = 'index', rowid");
      while (stmt.Step()) {
        const std::string type =
            reinterpret_cast<const char*>(sqlite3_column_text(stmt.get(), 0));
        if (type == "table") {
          tables.push_back(reinterpret_cast<const char*>(
              sqlite3_column_text(stmt.get(), 1)));
        }
        schema.push_back(
            reinterpret_cast<const char*>(sqlite3_column_text(stmt.get(), 2)));
      }
      for (const std::string& sql : schema) SqliteExec(db, sql + ";");
    }
    // COLMAP 3.8's tables the source lacks (descriptors and matches may be
    // absent: COLMAP's mapper does not read them).
    for (const std::string& sql : ColmapSchemaStatements()) SqliteExec(db, sql);
    {
      SqliteStatement version(db, "PRAGMA src.user_version");
      const int user_version =
          version.Step() ? sqlite3_column_int(version.get(), 0) : 0;
      SqliteExec(db, StrCat("PRAGMA main.user_version = ", user_version, ";"));
    }
    SqliteExec(db, "BEGIN;");
    // Copies the columns of `table` in both (all of them, the schema being
    // the source's), rows chosen by `where`.
    auto copy = [&](const std::string& table, const std::string& where) {
      std::string columns;
      SqliteStatement info(
          db, StrCat("SELECT name FROM pragma_table_info(", SqliteQuote(table),
                     ", 'main') WHERE name IN (SELECT name FROM "
                     "pragma_table_info(",
                     SqliteQuote(table), ", 'src')) ORDER BY cid"));
      while (info.Step()) {
        // COLMAP's column names: plain identifiers, quoted all the same.
        if (!columns.empty()) columns += ", ";
        columns += SqliteQuoteIdentifier(
            reinterpret_cast<const char*>(sqlite3_column_text(info.get(), 0)));
      }
      if (columns.empty()) return;  // No such table in the source.
      SqliteExec(db, StrCat("INSERT INTO main.", SqliteQuoteIdentifier(table), " (",
                            columns, ") SELECT ", columns, " FROM src.",
                            SqliteQuoteIdentifier(table), where, ";"));
    };
    // Every table but the pair tables and the descriptors, whole.
    for (const std::string& table : tables) {
      if (table != "two_view_geometries" && table != "matches" &&
          table != "descriptors") {
        copy(table, "");
      }
    }
    if (options.copy_descriptors) copy("descriptors", "");
    SqliteExec(db, "CREATE TEMP TABLE keep_pairs (pair_id INTEGER PRIMARY KEY);");
    {
      SqliteStatement insert(db, "INSERT OR IGNORE INTO keep_pairs VALUES (?)");
      for (const ImagePair& p : keep) {
        sqlite3_bind_int64(insert.get(), 1,
                           ImagePairToPairId(p.image_id1, p.image_id2));
        insert.Step();
        insert.Reset();
      }
    }
    const std::string kept =
        " WHERE pair_id IN (SELECT pair_id FROM keep_pairs)";
    copy("two_view_geometries", kept);
    if (options.copy_matches) copy("matches", kept);
    if (options.replace_inliers) {
      SqliteStatement update(db,
                             "UPDATE two_view_geometries SET rows = ?, cols = "
                             "2, data = ? WHERE pair_id = ?");
      for (const auto& [pair, matches] : *options.replace_inliers) {
        static_assert(sizeof(FeatureMatch) == 2 * sizeof(uint32_t),
                      "FeatureMatch is a pair of uint32 indices");
        sqlite3_bind_int64(update.get(), 1,
                           static_cast<sqlite3_int64>(matches.size()));
        sqlite3_bind_blob(update.get(), 2, matches.data(),
                          static_cast<int>(matches.size() *
                                           sizeof(FeatureMatch)),
                          SQLITE_TRANSIENT);
        sqlite3_bind_int64(update.get(), 3,
                           ImagePairToPairId(pair.image_id1, pair.image_id2));
        update.Step();
        update.Reset();
      }
    }
    SqliteExec(db, "COMMIT;");
    SqliteExec(db, "DETACH DATABASE src;");
  } catch (...) {
    sqlite3_close(db);
    fs::remove(temp_path, ec);
    throw;
  }
  sqlite3_close(db);
  fs::rename(temp_path, output_path, ec);
  ThrowUnless(!ec, StrCat("cannot rename ", temp_path, " to ", output_path));
}

}  // namespace hisfm
