#include "hisfm/io/database_merge.h"

#include <sqlite3.h>

#include <filesystem>
#include <random>
#include <unordered_map>

#include "hisfm/io/database.h"
#include "hisfm/io/sqlite_util.h"
#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"

namespace fs = std::filesystem;

namespace hisfm {
namespace {

// A new database under a temporary name beside `output_path`, with COLMAP's
// schema, renamed into place by Commit() and removed otherwise.
class TemporaryDatabase {
 public:
  explicit TemporaryDatabase(const std::string& output_path)
      : output_path_(output_path),
        temp_path_(output_path + ".tmp-" +
                   std::to_string(std::random_device()())) {
    std::error_code ec;
    fs::remove(temp_path_, ec);
    sqlite3* db = nullptr;
    if (sqlite3_open_v2(temp_path_.c_str(), &db,
                        SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE |
                            SQLITE_OPEN_URI,
                        nullptr) != SQLITE_OK) {
      sqlite3_close(db);
      throw Error(StrCat("cannot create database ", output_path));
    }
    db_.reset(db);
    for (const std::string& sql : ColmapSchemaStatements()) {
      SqliteExec(db_.get(), sql);
    }
  }
  ~TemporaryDatabase() {
    db_.reset();
    if (!committed_) {
      std::error_code ec;
      fs::remove(temp_path_, ec);
    }
  }
  sqlite3* get() const { return db_.get(); }
  void Commit() {
    db_.reset();
    std::error_code ec;
    fs::rename(temp_path_, output_path_, ec);
    ThrowUnless(!ec, StrCat("cannot rename ", temp_path_, " to ",
                            output_path_, ": ", ec.message()));
    committed_ = true;
  }

 private:
  std::string output_path_;
  std::string temp_path_;
  SqliteConnection db_;
  bool committed_ = false;
};

void Attach(sqlite3* db, const std::string& path) {
  CheckFileReadable(path, "database");
  SqliteExec(db, "ATTACH DATABASE " + SqliteQuote(ReadOnlyUri(path)) +
                     " AS src;");
}

// The columns of COLMAP 3.8's `table` that src's table has too, in schema
// order, without `exclude`, each as "x" and prefixed ", ".
std::string CommonColumns(sqlite3* db, const std::string& table,
                          const std::string& exclude,
                          const std::string& prefix) {
  std::string columns;
  SqliteStatement info(
      db, StrCat("SELECT name FROM pragma_table_info('", table,
                 "', 'main') WHERE name IN (SELECT name FROM "
                 "pragma_table_info('",
                 table, "', 'src')) ORDER BY cid"));
  while (info.Step()) {
    const std::string name =
        reinterpret_cast<const char*>(sqlite3_column_text(info.get(), 0));
    if (name == exclude) continue;
    columns += StrCat(", ", prefix, "\"", name, "\"");
  }
  return columns;
}

// True if src has `table`.
bool SourceHasTable(sqlite3* db, const std::string& table) {
  SqliteStatement q(db,
                    "SELECT count(*) FROM src.sqlite_master WHERE type = "
                    "'table' AND name = ?");
  sqlite3_bind_text(q.get(), 1, table.c_str(), -1, SQLITE_TRANSIENT);
  return q.Step() && sqlite3_column_int64(q.get(), 0) > 0;
}

struct SourceImage {
  int64_t image_id = 0;
  std::string name;
  int64_t camera_id = 0;
};

std::vector<SourceImage> ReadSourceImages(sqlite3* db,
                                          const std::string& schema) {
  std::vector<SourceImage> out;
  SqliteStatement q(db, StrCat("SELECT image_id, name, camera_id FROM ",
                               schema, ".images ORDER BY image_id"));
  while (q.Step()) {
    SourceImage im;
    im.image_id = sqlite3_column_int64(q.get(), 0);
    const unsigned char* text = sqlite3_column_text(q.get(), 1);
    im.name = text ? reinterpret_cast<const char*>(text) : "";
    im.camera_id = sqlite3_column_int64(q.get(), 2);
    out.push_back(std::move(im));
  }
  return out;
}

// The images of each shard, and the shard of each new image id.
struct ShardImages {
  std::vector<std::vector<SourceImage>> images;
  // For each new image id (1-based; 0 unused): the shard that holds it.
  std::vector<int> shard_of;
};

// Reads the images of every shard; throws unless each listed image is in
// exactly one shard and every shard image is listed.
ShardImages ReadShardImages(
    sqlite3* db, const std::vector<std::string>& shard_paths,
    const std::vector<std::string>& image_names,
    const std::unordered_map<std::string, int64_t>& new_id) {
  ShardImages shards;
  shards.images.resize(shard_paths.size());
  shards.shard_of.assign(image_names.size() + 1, -1);
  std::vector<int>& shard_of = shards.shard_of;
  for (size_t s = 0; s < shard_paths.size(); ++s) {
    Attach(db, shard_paths[s]);
    shards.images[s] = ReadSourceImages(db, "src");
    SqliteExec(db, "DETACH DATABASE src;");
    for (const SourceImage& im : shards.images[s]) {
      const auto it = new_id.find(im.name);
      ThrowUnless(it != new_id.end(),
                  StrCat("shard ", shard_paths[s], " holds image ", im.name,
                         ", which is not in the image list"));
      ThrowUnless(shard_of[it->second] < 0,
                  StrCat("image ", im.name, " is in two shards: ",
                         shard_of[it->second] >= 0
                             ? shard_paths[shard_of[it->second]]
                             : "",
                         " and ", shard_paths[s]));
      shard_of[it->second] = static_cast<int>(s);
    }
  }
  for (size_t i = 0; i < image_names.size(); ++i) {
    ThrowUnless(shard_of[i + 1] >= 0,
                StrCat("image ", image_names[i], " is in no feature shard"));
  }
  return shards;
}

// The merged database's camera ids.
struct CameraIds {
  // Per shard: old camera id -> new camera id.
  std::vector<std::unordered_map<int64_t, int64_t>> camera_map;
  // (shard, old id) of each new camera, in new id order.
  std::vector<std::pair<int, int64_t>> new_cameras;
};

// New camera ids in the order of the new image ids (all 1 with
// options.single_camera).
CameraIds NumberCameras(const ShardImages& shards, size_t num_images,
                        const std::unordered_map<std::string, int64_t>& new_id,
                        const FeatureShardMergeOptions& options) {
  const size_t num_shards = shards.images.size();
  CameraIds ids;
  ids.camera_map.resize(num_shards);
  std::vector<std::unordered_map<int64_t, const SourceImage*>> by_new_id(
      num_shards);
  for (size_t s = 0; s < num_shards; ++s) {
    for (const SourceImage& im : shards.images[s]) {
      by_new_id[s][new_id.at(im.name)] = &im;
    }
  }
  for (size_t i = 1; i <= num_images; ++i) {
    const int s = shards.shard_of[i];
    const SourceImage& im = *by_new_id[s].at(static_cast<int64_t>(i));
    auto& map = ids.camera_map[s];
    if (map.count(im.camera_id)) continue;
    if (options.single_camera && !ids.new_cameras.empty()) {
      map[im.camera_id] = 1;
      continue;
    }
    ids.new_cameras.emplace_back(s, im.camera_id);
    map[im.camera_id] = static_cast<int64_t>(ids.new_cameras.size());
  }
  return ids;
}

// Fills the temporary tables map_image and map_camera for shard `s`.
void FillIdMaps(sqlite3* db, size_t s, const std::vector<SourceImage>& images,
                const std::unordered_map<std::string, int64_t>& new_id,
                const CameraIds& cameras) {
  SqliteStatement insert(db, "INSERT INTO map_image VALUES (?, ?, ?)");
  for (const SourceImage& im : images) {
    sqlite3_bind_int64(insert.get(), 1, im.image_id);
    sqlite3_bind_int64(insert.get(), 2, new_id.at(im.name));
    sqlite3_bind_int64(insert.get(), 3,
                       cameras.camera_map[s].at(im.camera_id));
    insert.Step();
    insert.Reset();
  }
  SqliteStatement camera(db, "INSERT INTO map_camera VALUES (?, ?)");
  for (size_t c = 0; c < cameras.new_cameras.size(); ++c) {
    if (cameras.new_cameras[c].first != static_cast<int>(s)) continue;
    sqlite3_bind_int64(camera.get(), 1, cameras.new_cameras[c].second);
    sqlite3_bind_int64(camera.get(), 2, static_cast<int64_t>(c + 1));
    camera.Step();
    camera.Reset();
  }
}

// Throws naming the first image of the merged database without keypoints.
void CheckEveryImageHasKeypoints(sqlite3* db) {
  SqliteStatement missing(
      db,
      "SELECT name FROM images WHERE image_id NOT IN (SELECT image_id FROM "
      "keypoints) ORDER BY image_id LIMIT 1");
  if (missing.Step()) {
    throw Error(StrCat(
        "image ",
        reinterpret_cast<const char*>(sqlite3_column_text(missing.get(), 0)),
        " has no keypoints in its feature shard"));
  }
}

}  // namespace

void MergeFeatureShards(const std::vector<std::string>& shard_paths,
                        const std::vector<std::string>& image_names,
                        const std::string& output_path,
                        const FeatureShardMergeOptions& options) {
  options.Check();
  ThrowUnless(!shard_paths.empty(), "no feature shards to merge");
  std::unordered_map<std::string, int64_t> new_id;
  for (size_t i = 0; i < image_names.size(); ++i) {
    ThrowUnless(new_id.emplace(image_names[i], static_cast<int64_t>(i + 1))
                    .second,
                StrCat("image ", image_names[i], " is listed twice"));
  }
  TemporaryDatabase out(output_path);
  sqlite3* db = out.get();
  ShardImages shards = ReadShardImages(db, shard_paths, image_names, new_id);
  const CameraIds cameras =
      NumberCameras(shards, image_names.size(), new_id, options);

  SqliteExec(db,
             "CREATE TEMP TABLE map_image (old INTEGER PRIMARY KEY, new "
             "INTEGER, camera INTEGER);"
             "CREATE TEMP TABLE map_camera (old INTEGER PRIMARY KEY, new "
             "INTEGER);");
  for (size_t s = 0; s < shard_paths.size(); ++s) {
    // One transaction per shard: SQLite attaches only outside of one.
    Attach(db, shard_paths[s]);
    SqliteExec(db, "BEGIN;");
    SqliteExec(db, "DELETE FROM map_image; DELETE FROM map_camera;");
    FillIdMaps(db, s, shards.images[s], new_id, cameras);
    const std::string camera_columns =
        CommonColumns(db, "cameras", "camera_id", "c.");
    SqliteExec(db, StrCat("INSERT INTO main.cameras (camera_id",
                          CommonColumns(db, "cameras", "camera_id", ""),
                          ") SELECT m.new", camera_columns,
                          " FROM src.cameras c JOIN map_camera m ON "
                          "c.camera_id = m.old;"));
    const std::string image_columns =
        CommonColumns(db, "images", "image_id", "");
    std::string image_select;
    {
      // Finalized before src is detached (a live statement locks it).
      SqliteStatement info(
          db, StrCat("SELECT name FROM pragma_table_info('images', 'main') "
                     "WHERE name IN (SELECT name FROM "
                     "pragma_table_info('images', 'src')) AND name != "
                     "'image_id' ORDER BY cid"));
      while (info.Step()) {
        const std::string name =
            reinterpret_cast<const char*>(sqlite3_column_text(info.get(), 0));
        image_select += name == "camera_id" ? std::string(", m.camera")
                                            : StrCat(", i.\"", name, "\"");
      }
    }
    SqliteExec(db, StrCat("INSERT INTO main.images (image_id", image_columns,
                          ") SELECT m.new", image_select,
                          " FROM src.images i JOIN map_image m ON "
                          "i.image_id = m.old;"));
    for (const char* table : {"keypoints", "descriptors"}) {
      if (!SourceHasTable(db, table)) continue;
      SqliteExec(db, StrCat("INSERT INTO main.", table, " (image_id",
                            CommonColumns(db, table, "image_id", ""),
                            ") SELECT m.new",
                            CommonColumns(db, table, "image_id", "t."),
                            " FROM src.", table,
                            " t JOIN map_image m ON t.image_id = m.old;"));
    }
    SqliteExec(db, "COMMIT;");
    SqliteExec(db, "DETACH DATABASE src;");
  }
  CheckEveryImageHasKeypoints(db);
  out.Commit();
}

MatchBlockMergeStats MergeMatchBlocks(
    const std::string& features_path,
    const std::vector<std::string>& block_paths,
    const std::string& output_path) {
  MatchBlockMergeStats stats;
  TemporaryDatabase out(output_path);
  sqlite3* db = out.get();
  Attach(db, features_path);
  SqliteExec(db, "BEGIN;");
  for (const char* table : {"cameras", "images", "keypoints", "descriptors"}) {
    if (!SourceHasTable(db, table)) continue;
    const std::string columns = CommonColumns(db, table, "", "").substr(2);
    SqliteExec(db, StrCat("INSERT INTO main.", table, " (", columns,
                          ") SELECT ", columns, " FROM src.", table, ";"));
  }
  const std::vector<SourceImage> images = ReadSourceImages(db, "main");
  SqliteExec(db, "COMMIT;");
  SqliteExec(db, "DETACH DATABASE src;");
  SqliteExec(db, "BEGIN;");
  for (const std::string& block : block_paths) {
    Attach(db, block);
    const std::vector<SourceImage> block_images = ReadSourceImages(db, "src");
    bool same = block_images.size() == images.size();
    for (size_t i = 0; same && i < images.size(); ++i) {
      same = block_images[i].image_id == images[i].image_id &&
             block_images[i].name == images[i].name;
    }
    ThrowUnless(same, StrCat("matching block ", block,
                             " has other images than the features "
                             "database ", features_path));
    for (const char* table : {"matches", "two_view_geometries"}) {
      if (!SourceHasTable(db, table)) continue;
      const bool verified = std::string(table) == "two_view_geometries";
      SqliteStatement count(
          db, StrCat("SELECT count(*) FROM src.", table,
                     " WHERE pair_id IN (SELECT pair_id FROM main.", table,
                     ")"));
      if (verified && count.Step()) {
        stats.duplicate_pairs +=
            static_cast<size_t>(sqlite3_column_int64(count.get(), 0));
      }
      const std::string columns = CommonColumns(db, table, "", "").substr(2);
      SqliteExec(db, StrCat("INSERT OR IGNORE INTO main.", table, " (",
                            columns, ") SELECT ", columns, " FROM src.", table,
                            ";"));
    }
    SqliteExec(db, "COMMIT;");
    SqliteExec(db, "DETACH DATABASE src;");
    SqliteExec(db, "BEGIN;");
  }
  SqliteExec(db, "COMMIT;");
  {
    SqliteStatement q(db, "SELECT (SELECT count(*) FROM matches), (SELECT "
                          "count(*) FROM two_view_geometries)");
    if (q.Step()) {
      stats.matched_pairs =
          static_cast<size_t>(sqlite3_column_int64(q.get(), 0));
      stats.verified_pairs =
          static_cast<size_t>(sqlite3_column_int64(q.get(), 1));
    }
  }
  out.Commit();
  return stats;
}

}  // namespace hisfm
