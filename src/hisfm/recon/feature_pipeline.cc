#include "hisfm/recon/feature_pipeline.h"

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <sstream>

#include <sqlite3.h>

#include "hisfm/io/database.h"
#include "hisfm/io/sqlite_util.h"
#include "hisfm/recon/slurm_feature_stages.h"
#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"
#include "hisfm/util/logging.h"
#include "hisfm/util/timer.h"

namespace fs = std::filesystem;

namespace hisfm {

// ---------------------------------------------------------------------------
// Image headers.

std::string ImageFormatName(ImageFormat format) {
  switch (format) {
    case ImageFormat::kJpeg:
      return "JPEG";
    case ImageFormat::kPng:
      return "PNG";
    case ImageFormat::kTiff:
      return "TIFF";
    case ImageFormat::kBmp:
      return "BMP";
    case ImageFormat::kUnknown:
      break;
  }
  return "unknown";
}

namespace {

// Random-access reads of a file's bytes.
class ByteReader {
 public:
  explicit ByteReader(const std::string& path)
      : in_(path, std::ios::binary) {
    if (in_) {
      in_.seekg(0, std::ios::end);
      size_ = static_cast<uint64_t>(in_.tellg());
      in_.seekg(0);
    }
  }
  bool ok() const { return static_cast<bool>(in_); }
  uint64_t size() const { return size_; }
  // Reads n bytes at offset; false if the file is shorter.
  bool Read(uint64_t offset, size_t n, uint8_t* out) {
    if (offset + n > size_) return false;
    in_.clear();
    in_.seekg(static_cast<std::streamoff>(offset));
    in_.read(reinterpret_cast<char*>(out), static_cast<std::streamsize>(n));
    return static_cast<size_t>(in_.gcount()) == n;
  }

 private:
  std::ifstream in_;
  uint64_t size_ = 0;
};

uint32_t Be16(const uint8_t* p) { return (uint32_t{p[0]} << 8) | p[1]; }
uint32_t Be32(const uint8_t* p) {
  return (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) |
         (uint32_t{p[2]} << 8) | p[3];
}
uint32_t Le16(const uint8_t* p) { return (uint32_t{p[1]} << 8) | p[0]; }
uint32_t Le32(const uint8_t* p) {
  return (uint32_t{p[3]} << 24) | (uint32_t{p[2]} << 16) |
         (uint32_t{p[1]} << 8) | p[0];
}

// JPEG: walk the marker segments up to the first start-of-frame.
bool JpegSize(ByteReader& r, int* width, int* height, std::string* reason) {
  uint64_t pos = 2;
  uint8_t b[9];
  while (true) {
    if (!r.Read(pos, 2, b)) break;
    if (b[0] != 0xFF) {
      *reason = "corrupt JPEG header";
      return false;
    }
    uint8_t marker = b[1];
    // Fill bytes.
    while (marker == 0xFF) {
      ++pos;
      if (!r.Read(pos, 2, b)) break;
      marker = b[1];
    }
    if (marker == 0xFF) break;
    pos += 2;
    if (marker == 0x01 || (marker >= 0xD0 && marker <= 0xD7)) continue;
    if (marker == 0xD9 || marker == 0xDA) {
      *reason = "JPEG without a frame header";
      return false;
    }
    if (!r.Read(pos, 2, b)) break;
    const uint32_t length = Be16(b);
    if (length < 2) {
      *reason = "corrupt JPEG header";
      return false;
    }
    const bool sof = marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 &&
                     marker != 0xC8 && marker != 0xCC;
    if (sof) {
      if (!r.Read(pos, 7, b)) break;
      *height = static_cast<int>(Be16(b + 3));
      *width = static_cast<int>(Be16(b + 5));
      return true;
    }
    pos += length;
  }
  *reason = "truncated JPEG header";
  return false;
}

bool TiffSize(ByteReader& r, bool little, int* width, int* height,
              std::string* reason) {
  auto u16 = [&](const uint8_t* p) { return little ? Le16(p) : Be16(p); };
  auto u32 = [&](const uint8_t* p) { return little ? Le32(p) : Be32(p); };
  uint8_t b[12];
  if (!r.Read(4, 4, b)) {
    *reason = "truncated TIFF header";
    return false;
  }
  const uint64_t ifd = u32(b);
  if (!r.Read(ifd, 2, b)) {
    *reason = "truncated TIFF header";
    return false;
  }
  const uint32_t count = u16(b);
  int w = 0, h = 0;
  for (uint32_t i = 0; i < count; ++i) {
    if (!r.Read(ifd + 2 + 12 * uint64_t{i}, 12, b)) {
      *reason = "truncated TIFF header";
      return false;
    }
    const uint32_t tag = u16(b);
    const uint32_t type = u16(b + 2);
    const uint32_t value = type == 3 ? u16(b + 8) : u32(b + 8);
    if (type != 3 && type != 4) continue;
    if (tag == 256) w = static_cast<int>(value);
    if (tag == 257) h = static_cast<int>(value);
  }
  if (w <= 0 || h <= 0) {
    *reason = "TIFF without an image size";
    return false;
  }
  *width = w;
  *height = h;
  return true;
}

}  // namespace

bool ReadImageHeader(const std::string& path, ImageFileInfo* info,
                     std::string* reason) {
  ByteReader r(path);
  if (!r.ok()) {
    *reason = "cannot be opened";
    return false;
  }
  uint8_t b[26] = {0};
  if (!r.Read(0, std::min<uint64_t>(r.size(), 26), b) || r.size() < 8) {
    *reason = r.size() == 0 ? "empty file" : "too short for an image";
    return false;
  }
  int width = 0, height = 0;
  ImageFormat format = ImageFormat::kUnknown;
  if (b[0] == 0xFF && b[1] == 0xD8 && b[2] == 0xFF) {
    format = ImageFormat::kJpeg;
    if (!JpegSize(r, &width, &height, reason)) return false;
  } else if (std::memcmp(b, "\x89PNG\r\n\x1a\n", 8) == 0) {
    format = ImageFormat::kPng;
    if (r.size() < 24 || std::memcmp(b + 12, "IHDR", 4) != 0) {
      *reason = "truncated PNG header";
      return false;
    }
    width = static_cast<int>(Be32(b + 16));
    height = static_cast<int>(Be32(b + 20));
  } else if ((b[0] == 'I' && b[1] == 'I' && b[2] == 42 && b[3] == 0) ||
             (b[0] == 'M' && b[1] == 'M' && b[2] == 0 && b[3] == 42)) {
    format = ImageFormat::kTiff;
    if (!TiffSize(r, b[0] == 'I', &width, &height, reason)) return false;
  } else if (b[0] == 'B' && b[1] == 'M') {
    format = ImageFormat::kBmp;
    if (r.size() < 26) {
      *reason = "truncated BMP header";
      return false;
    }
    const uint32_t dib = Le32(b + 14);
    if (dib == 12) {
      width = static_cast<int>(Le16(b + 18));
      height = static_cast<int>(Le16(b + 20));
    } else {
      width = static_cast<int32_t>(Le32(b + 18));
      height = std::abs(static_cast<int32_t>(Le32(b + 22)));
    }
  } else {
    *reason = "not a JPEG, PNG, TIFF or BMP file";
    return false;
  }
  if (width <= 0 || height <= 0) {
    *reason = StrCat("invalid ", ImageFormatName(format), " image size");
    return false;
  }
  info->format = format;
  info->width = width;
  info->height = height;
  return true;
}

ImageFolderScan ScanImageFolder(const std::string& image_path) {
  std::error_code ec;
  ThrowUnless(!image_path.empty(), "--image_path is required");
  ThrowUnless(fs::is_directory(image_path, ec),
              StrCat("image folder not found: ", image_path));
  ImageFolderScan scan;
  const fs::path root(image_path);
  fs::recursive_directory_iterator it(root, ec);
  ThrowUnless(!ec, StrCat("cannot read image folder ", image_path, ": ",
                          ec.message()));
  size_t num_files = 0;
  for (; it != fs::recursive_directory_iterator(); it.increment(ec)) {
    if (ec) break;
    const fs::path& p = it->path();
    if (p.filename().string().rfind('.', 0) == 0) {
      if (it->is_directory(ec)) it.disable_recursion_pending();
      continue;
    }
    if (!it->is_regular_file(ec)) continue;
    ++num_files;
    const std::string name = p.lexically_relative(root).generic_string();
    if (name.find_first_of("\n\r") != std::string::npos) {
      scan.skipped.push_back({name, "name contains a line break"});
      continue;
    }
    ImageFileInfo info;
    info.name = name;
    std::string reason;
    if (!ReadImageHeader(p.string(), &info, &reason)) {
      scan.skipped.push_back({name, reason});
      continue;
    }
    struct stat st;
    if (stat(p.c_str(), &st) != 0) {
      scan.skipped.push_back({name, "cannot be stat-ed"});
      continue;
    }
    info.file_size = static_cast<uint64_t>(st.st_size);
    info.mtime_ns = static_cast<int64_t>(st.st_mtim.tv_sec) * 1000000000 +
                    st.st_mtim.tv_nsec;
    scan.images.push_back(std::move(info));
  }
  ThrowUnless(!ec, StrCat("cannot read image folder ", image_path, ": ",
                          ec.message()));
  ThrowUnless(num_files > 0, StrCat("image folder is empty: ", image_path));
  ThrowUnless(!scan.images.empty(),
              StrCat("no readable image in ", image_path, " (", num_files,
                     " file(s), none a JPEG, PNG, TIFF or BMP image)"));
  std::sort(scan.images.begin(), scan.images.end(),
            [](const ImageFileInfo& a, const ImageFileInfo& b) {
              return a.name < b.name;
            });
  std::sort(scan.skipped.begin(), scan.skipped.end(),
            [](const SkippedImageFile& a, const SkippedImageFile& b) {
              return a.name < b.name;
            });
  return scan;
}

// ---------------------------------------------------------------------------
// Options.

CameraMode ParseCameraMode(const std::string& name) {
  if (name == "single") return CameraMode::kSingle;
  if (name == "per_image") return CameraMode::kPerImage;
  if (name == "auto") return CameraMode::kAuto;
  throw Error(StrCat("unknown camera mode '", name,
                     "': use single, per_image or auto"));
}

std::string CameraModeName(CameraMode mode) {
  switch (mode) {
    case CameraMode::kSingle:
      return "single";
    case CameraMode::kPerImage:
      return "per_image";
    case CameraMode::kAuto:
      break;
  }
  return "auto";
}

CameraMode ResolveCameraMode(CameraMode mode,
                             const std::vector<ImageFileInfo>& images) {
  if (mode != CameraMode::kAuto) return mode;
  for (const ImageFileInfo& im : images) {
    if (im.width != images.front().width ||
        im.height != images.front().height) {
      return CameraMode::kPerImage;
    }
  }
  return CameraMode::kSingle;
}

void FeaturePipelineOptions::Check() const {
  HISFM_CHECK_OPTION(matcher,
                     matcher == "exhaustive" || matcher == "sequential" ||
                     matcher == "vocab_tree",
                     "one of exhaustive, sequential, vocab_tree");
  HISFM_CHECK_OPTION(num_neighbors, num_neighbors >= 1, ">= 1");
  HISFM_CHECK_OPTION(vocab_tree_num_words,
                     vocab_tree_num_words == 0 || vocab_tree_num_words >= 16,
                     "0 or >= 16");
  HISFM_CHECK_OPTION(executor, executor == "local" || executor == "slurm",
                     "one of local, slurm");
  HISFM_CHECK_OPTION(shard_size, shard_size >= 0, ">= 0");
  HISFM_CHECK_OPTION(block_group_size, block_group_size >= 0, ">= 0");
  if (executor == "slurm") slurm.Check();
  ParseCameraMode(camera_mode);
  HISFM_CHECK_OPTION(camera_model, !camera_model.empty(), "non-empty");
  HISFM_CHECK_OPTION(num_threads,
                     num_threads == -1 || num_threads >= 1, "-1 or >= 1");
  HISFM_CHECK_OPTION(exhaustive_block_size,
                     exhaustive_block_size == 0 || exhaustive_block_size >= 2,
                     "0 or >= 2");
  colmap.Check();
}

int ExhaustiveBlockSize(const FeaturePipelineOptions& options,
                        size_t num_images) {
  if (options.exhaustive_block_size > 0) return options.exhaustive_block_size;
  const int quarter = static_cast<int>((num_images + 3) / 4);
  return std::clamp(quarter, 5, 50);
}

int VocabTreeBuildWords(const FeaturePipelineOptions& options,
                        size_t num_images) {
  if (options.vocab_tree_num_words > 0) return options.vocab_tree_num_words;
  int words = 256;
  while (words < 65536 && static_cast<size_t>(words) < 64 * num_images) {
    words *= 2;
  }
  return words;
}

int VocabTreeBuildBranching(int num_words) {
  return num_words < 4096 ? 16 : 32;
}

size_t VocabTreeBuildImages(size_t num_images, double mean_descriptors) {
  if (!(mean_descriptors > 0)) return num_images;
  const double images = 200000.0 / mean_descriptors;
  return std::clamp<size_t>(static_cast<size_t>(images), 1, num_images);
}

// ---------------------------------------------------------------------------
// Progress lines.

namespace {

// Parses "<prefix>[a/b" at the start of `line` (after spaces).
bool ParseBracket(const std::string& line, const char* prefix, size_t* a,
                  size_t* b, size_t* end) {
  const size_t start = line.find(prefix);
  if (start == std::string::npos) return false;
  size_t pos = start + std::strlen(prefix);
  unsigned long x = 0, y = 0;
  int consumed = 0;
  if (std::sscanf(line.c_str() + pos, "%lu/%lu%n", &x, &y, &consumed) != 2) {
    return false;
  }
  *a = x;
  *b = y;
  if (end) *end = pos + static_cast<size_t>(consumed);
  return y > 0;
}

}  // namespace

bool ParseExtractionProgress(const std::string& line, size_t* done,
                             size_t* total) {
  return ParseBracket(line, "Processed file [", done, total, nullptr);
}

// COLMAP 3.13 renamed the matchers' progress lines "Matching block [" and
// "Matching image [" to "Processing block [" and "Processing image ["; the
// mapper's "Registering image #ID (N)" (N registered, this one included)
// became "Registering image #ID (num_reg_frames=N)" in 3.12 (N registered
// before this one).

bool ParseExhaustiveProgress(const std::string& line, size_t* done,
                             size_t* total) {
  size_t i = 0, n = 0, j = 0, m = 0, end = 0;
  if (!ParseBracket(line, "Matching block [", &i, &n, &end) &&
      !ParseBracket(line, "Processing block [", &i, &n, &end)) {
    return false;
  }
  unsigned long x = 0, y = 0;
  if (std::sscanf(line.c_str() + end, ", %lu/%lu", &x, &y) != 2) return false;
  j = x;
  m = y;
  if (i < 1 || j < 1 || m == 0) return false;
  *done = (i - 1) * m + j;
  *total = n * m;
  return true;
}

bool ParseSequentialProgress(const std::string& line, size_t* done,
                             size_t* total) {
  return ParseBracket(line, "Matching image [", done, total, nullptr) ||
         ParseBracket(line, "Processing image [", done, total, nullptr);
}

bool ParseMapperProgress(const std::string& line, size_t* done,
                         size_t* /*total*/) {
  const size_t pos = line.find("Registering image #");
  if (pos == std::string::npos) return false;
  unsigned long id = 0, n = 0;
  if (std::sscanf(line.c_str() + pos, "Registering image #%lu (%lu)", &id,
                  &n) == 2) {
    *done = n;
    return true;
  }
  if (std::sscanf(line.c_str() + pos,
                  "Registering image #%lu (num_reg_frames=%lu)", &id,
                  &n) == 2) {
    *done = n + 1;
    return true;
  }
  return false;
}

// ---------------------------------------------------------------------------
// Log follower.

struct ColmapLogFollower::State {
  std::string path;
  std::string what;
  size_t total = 0;
  ProgressLineParser parser;
  double poll_seconds = 0.25;
  uint64_t offset = 0;
  ino_t inode = 0;
  std::string partial;
  std::unique_ptr<ProgressReporter> reporter;
  bool any_progress = false;
  bool stopped = false;
  Timer timer;
};

ColmapLogFollower::ColmapLogFollower(std::string log_path, std::string what,
                                     size_t total, ProgressLineParser parser,
                                     double poll_seconds)
    : state_(std::make_unique<State>()) {
  State& s = *state_;
  s.path = std::move(log_path);
  s.what = std::move(what);
  s.total = total;
  s.parser = std::move(parser);
  s.poll_seconds = poll_seconds;
  struct stat st;
  if (stat(s.path.c_str(), &st) == 0) {
    s.offset = static_cast<uint64_t>(st.st_size);
    s.inode = st.st_ino;
  }
  s.reporter = std::make_unique<ProgressReporter>(s.what, std::max<size_t>(
                                                              s.total, 1));
  thread_ = std::thread([this] { Run(); });
}

ColmapLogFollower::~ColmapLogFollower() { Stop(); }

bool ColmapLogFollower::Poll() {
  State& s = *state_;
  struct stat st;
  if (stat(s.path.c_str(), &st) != 0) return false;
  if (st.st_ino != s.inode || static_cast<uint64_t>(st.st_size) < s.offset) {
    s.inode = st.st_ino;
    s.offset = 0;
    s.partial.clear();
  }
  if (static_cast<uint64_t>(st.st_size) == s.offset) return false;
  std::ifstream in(s.path, std::ios::binary);
  if (!in) return false;
  in.seekg(static_cast<std::streamoff>(s.offset));
  std::string chunk(static_cast<size_t>(st.st_size) - s.offset, '\0');
  in.read(chunk.data(), static_cast<std::streamsize>(chunk.size()));
  chunk.resize(static_cast<size_t>(in.gcount()));
  s.offset += chunk.size();
  s.partial += chunk;
  size_t start = 0;
  size_t newline;
  while ((newline = s.partial.find_first_of("\n\r", start)) !=
         std::string::npos) {
    const std::string line = s.partial.substr(start, newline - start);
    start = newline + 1;
    size_t done = 0, total = 0;
    if (line.empty() || !s.parser(line, &done, &total)) continue;
    if (total > 0 && total != s.total) {
      s.total = total;
      s.reporter = std::make_unique<ProgressReporter>(s.what, s.total);
    }
    done_.store(std::min(done, std::max<size_t>(s.total, done)));
    s.any_progress = true;
  }
  s.partial.erase(0, start);
  return true;
}

void ColmapLogFollower::Run() {
  State& s = *state_;
  while (!stop_.load()) {
    Poll();
    if (s.any_progress) s.reporter->Update(std::min(done_.load(), s.total));
    std::this_thread::sleep_for(
        std::chrono::milliseconds(static_cast<int>(s.poll_seconds * 1000)));
  }
}

void ColmapLogFollower::Stop() {
  State& s = *state_;
  if (s.stopped) return;
  s.stopped = true;
  stop_.store(true);
  if (thread_.joinable()) thread_.join();
  Poll();
  const size_t done = done_.load();
  if (s.total > 0 && done >= s.total) {
    s.reporter->Finish();
    return;
  }
  if (isatty(fileno(stderr)) != 0) {
    std::fprintf(stderr, "\r\033[K");
    std::fflush(stderr);
  }
  if (s.any_progress) {
    HISFM_LOG_INFO("{}: {}/{} in {:.1f} s", s.what, done, s.total,
                   s.timer.ElapsedSeconds());
  }
}

double RunColmapWithProgress(const ColmapRunnerOptions& options,
                             const std::vector<std::string>& args,
                             const std::string& log_path,
                             const std::string& what, size_t total,
                             const ProgressLineParser& parser) {
  ColmapLogFollower follower(log_path, what, total, parser);
  const double seconds = RunColmap(options, args, log_path);
  follower.Stop();
  return seconds;
}

// ---------------------------------------------------------------------------
// Ledger.

std::string TextFingerprint(const std::string& text) {
  uint64_t h = 1469598103934665603ull;
  for (unsigned char c : text) {
    h ^= c;
    h *= 1099511628211ull;
  }
  char buf[17];
  std::snprintf(buf, sizeof(buf), "%016llx",
                static_cast<unsigned long long>(h));
  return buf;
}

namespace {

// "size:mtime_ns" of a file, or "" if it does not exist.
std::string FileStamp(const std::string& path) {
  struct stat st;
  if (stat(path.c_str(), &st) != 0) return "";
  return StrCat(st.st_size, ":",
                static_cast<int64_t>(st.st_mtim.tv_sec) * 1000000000 +
                    st.st_mtim.tv_nsec);
}

std::string NowIso() {
  const std::time_t t = std::time(nullptr);
  std::tm tm{};
  localtime_r(&t, &tm);
  char buf[32];
  std::strftime(buf, sizeof(buf), "%Y-%m-%dT%H:%M:%S", &tm);
  return buf;
}

}  // namespace

StageLedger::StageLedger(std::string path) : path_(std::move(path)) {
  json_ = {{"stages", nlohmann::json::object()}};
  std::ifstream in(path_);
  if (!in) return;
  try {
    nlohmann::json j = nlohmann::json::parse(in);
    if (j.is_object() && j.contains("stages") && j["stages"].is_object()) {
      json_ = std::move(j);
    }
  } catch (const nlohmann::json::exception&) {
    HISFM_LOG_WARN("ignoring unreadable stage record {}", path_);
  }
}

bool StageLedger::IsDone(const std::string& stage,
                         const std::string& fingerprint) const {
  const nlohmann::json& stages = json_["stages"];
  if (!stages.contains(stage)) return false;
  const nlohmann::json& s = stages[stage];
  if (s.value("fingerprint", "") != fingerprint) return false;
  if (s.contains("outputs")) {
    for (const auto& [path, stamp] : s["outputs"].items()) {
      if (FileStamp(path) != stamp.get<std::string>()) return false;
    }
  }
  return true;
}

void StageLedger::MarkDone(const std::string& stage,
                           const std::string& fingerprint, double seconds,
                           const std::vector<std::string>& outputs,
                           const nlohmann::json& info) {
  nlohmann::json out = nlohmann::json::object();
  for (const std::string& path : outputs) out[path] = FileStamp(path);
  json_["stages"][stage] = {{"fingerprint", fingerprint},
                            {"seconds", seconds},
                            {"finished", NowIso()},
                            {"outputs", out},
                            {"info", info}};
  Save();
}

void StageLedger::Invalidate(const std::string& stage) {
  if (json_["stages"].erase(stage) > 0) Save();
}

double StageLedger::Seconds(const std::string& stage) const {
  const nlohmann::json& stages = json_["stages"];
  if (!stages.contains(stage)) return 0.0;
  return stages[stage].value("seconds", 0.0);
}

nlohmann::json StageLedger::Info(const std::string& stage) const {
  const nlohmann::json& stages = json_["stages"];
  if (!stages.contains(stage)) return nullptr;
  return stages[stage].value("info", nlohmann::json());
}

void StageLedger::Save() const {
  WriteFileAtomically(path_, json_.dump(2) + "\n");
}

// ---------------------------------------------------------------------------
// The pipeline.

namespace {

void RemoveDatabaseFiles(const std::string& path) {
  std::error_code ec;
  for (const char* suffix : {"", "-wal", "-shm", "-journal"}) {
    fs::remove(path + suffix, ec);
  }
}

// Deletes all matches and verified pairs of a database, keeping cameras,
// images and features, so that a new matching starts from the features only.
void ClearMatches(const std::string& path) {
  sqlite3* db = nullptr;
  const int rc = sqlite3_open_v2(path.c_str(), &db, SQLITE_OPEN_READWRITE,
                                 nullptr);
  if (rc != SQLITE_OK) {
    sqlite3_close(db);
    throw Error(StrCat("cannot open database ", path));
  }
  try {
    SqliteExec(db, "DELETE FROM matches; DELETE FROM two_view_geometries;");
  } catch (...) {
    sqlite3_close(db);
    throw;
  }
  sqlite3_close(db);
}

// Mean number of descriptors per image of a database (0 if none).
double MeanDescriptors(const std::string& path) {
  SqliteConnection db = OpenReadOnlyConnection(path);
  if (!db) return 0.0;
  SqliteStatement q(db.get(), "SELECT avg(rows) FROM descriptors");
  return q.Step() ? sqlite3_column_double(q.get(), 0) : 0.0;
}

std::string JoinArgs(const std::vector<std::string>& args) {
  std::string out;
  for (const std::string& a : args) out += a + '\x1f';
  return out;
}

// The --SequentialMatching.* flags of the matcher arguments that decide the
// pairs (COLMAP's defaults otherwise).
struct SequentialMatchingFlags {
  size_t overlap = 10;
  bool quadratic = true;
};

SequentialMatchingFlags ReadSequentialMatchingFlags(
    const std::vector<std::string>& args) {
  SequentialMatchingFlags flags;
  for (size_t i = 0; i + 1 < args.size(); ++i) {
    if (args[i] == "--SequentialMatching.overlap") {
      flags.overlap = static_cast<size_t>(std::stoul(args[i + 1]));
    } else if (args[i] == "--SequentialMatching.quadratic_overlap") {
      flags.quadratic = args[i + 1] != "0" && args[i + 1] != "false";
    }
  }
  return flags;
}

// The --SiftMatching.* flags (with their values) of the matcher arguments:
// what matches_importer and vocab_tree_matcher accept of them.
std::vector<std::string> SiftMatchingArgs(
    const std::vector<std::string>& args) {
  std::vector<std::string> out;
  for (size_t i = 0; i < args.size(); ++i) {
    if (args[i].rfind("--SiftMatching.", 0) != 0) continue;
    out.push_back(args[i]);
    if (i + 1 < args.size() && args[i + 1].rfind("--", 0) != 0) {
      out.push_back(args[++i]);
    }
  }
  return out;
}

// What the stages of one pipeline run share.
struct PipelineRun {
  const FeaturePipelineOptions& options;
  // The workspace and the image folder, absolute.
  std::string ws;
  std::string images_abs;
  // The image list (workspace/image_list.txt) and the database.
  std::string list_path;
  std::string database;
  StageLedger* ledger = nullptr;
  FeaturePipelineResult* result = nullptr;

  bool OnSlurm() const { return options.executor == "slurm"; }
};

// Keeps the scan's skipped files outside the workspace (which may sit
// inside the image folder), lists them in skipped_images.txt and warns
// about them.
std::vector<SkippedImageFile> RecordSkippedFiles(
    const std::vector<SkippedImageFile>& scanned, const std::string& ws,
    const std::string& images_abs) {
  std::vector<SkippedImageFile> skipped;
  for (const SkippedImageFile& s : scanned) {
    const std::string full =
        (fs::path(images_abs) / s.name).lexically_normal().string();
    if (full.rfind(ws + "/", 0) != 0) skipped.push_back(s);
  }
  {
    std::string text;
    for (const SkippedImageFile& s : skipped) {
      text += s.name + "\t" + s.reason + "\n";
    }
    WriteFileAtomically(ws + "/skipped_images.txt", text);
  }
  if (!skipped.empty()) {
    std::string list;
    for (size_t i = 0; i < skipped.size() && i < 10; ++i) {
      list += (i ? ", " : "") + skipped[i].name + " (" + skipped[i].reason +
              ")";
    }
    if (skipped.size() > 10) list += StrCat(", ... (", skipped.size(), ")");
    HISFM_LOG_WARN("skipping {} file(s) that are not readable images: {}",
                   skipped.size(), list);
  }
  return skipped;
}

// Writes the image list (`list_path`, rewritten only when it changes) and
// returns the images' record for the features' fingerprint: the folder,
// then name, size, time and dimensions of each image.
std::string WriteImageList(const std::vector<ImageFileInfo>& images,
                           const std::string& images_abs,
                           const std::string& list_path) {
  std::string list_text;
  std::ostringstream images_record;
  images_record << images_abs << '\n';
  for (const ImageFileInfo& im : images) {
    list_text += im.name + "\n";
    images_record << im.name << '\t' << im.file_size << '\t' << im.mtime_ns
                  << '\t' << im.width << 'x' << im.height << '\n';
  }
  if (!fs::exists(list_path) || ReadTextFile(list_path) != list_text) {
    WriteFileAtomically(list_path, list_text);
  }
  return images_record.str();
}

// Stage: feature extraction into a new database, on Slurm or with colmap
// feature_extractor, unless the ledger holds it with `features_fp`.
void ExtractFeatures(const PipelineRun& run, const std::string& features_fp,
                     const std::vector<std::string>& image_names) {
  const FeaturePipelineOptions& options = run.options;
  FeaturePipelineResult& result = *run.result;
  StageLedger& ledger = *run.ledger;
  const std::string& ws = run.ws;
  const std::string& database = run.database;
  const bool on_slurm = run.OnSlurm();
  if (ledger.IsDone("features", features_fp) && fs::exists(database)) {
    result.extraction_skipped = true;
    HISFM_LOG_INFO("features: unchanged since the last run, skipped");
    return;
  }
  ledger.Invalidate("matching");
  ledger.Invalidate("vocab_tree");
  ledger.Invalidate("features");
  const std::string tmp = ws + "/database.features.tmp.db";
  RemoveDatabaseFiles(tmp);
  Timer timer;
  if (on_slurm) {
    SlurmExtractionJob job;
    job.image_path = run.images_abs;
    job.image_names = image_names;
    job.shard_size = options.shard_size > 0
                         ? static_cast<size_t>(options.shard_size)
                         : PieceSize(image_names.size(), 8);
    job.single_camera = result.camera_mode == CameraMode::kSingle;
    job.camera_model = options.camera_model;
    job.extractor_args = options.extractor_args;
    job.fingerprint = features_fp;
    result.feature_shards = ExtractFeaturesOnSlurm(
        job, options.colmap, options.slurm, ws + "/slurm/features", tmp);
    result.extraction_seconds = timer.ElapsedSeconds();
  } else {
    LogHeading(StrCat("Extracting features of ", image_names.size(),
                      " image(s) (colmap feature_extractor, CPU)"));
    std::vector<std::string> args = {
        "feature_extractor",        "--database_path",
        tmp,                        "--image_path",
        run.images_abs,             "--image_list_path",
        run.list_path,              "--SiftExtraction.use_gpu",
        "0",                        "--SiftExtraction.num_threads",
        std::to_string(options.num_threads),
        "--ImageReader.camera_model", options.camera_model};
    if (result.camera_mode == CameraMode::kSingle) {
      args.insert(args.end(), {"--ImageReader.single_camera", "1"});
    } else {
      args.insert(args.end(), {"--ImageReader.single_camera_per_image", "1"});
    }
    args.insert(args.end(), options.extractor_args.begin(),
                options.extractor_args.end());
    result.extraction_seconds = RunColmapWithProgress(
        options.colmap, args, ws + "/logs/feature_extractor.log",
        "Extracting features", image_names.size(), ParseExtractionProgress);
  }
  size_t num_in_db = 0;
  {
    Database db(tmp);
    num_in_db = db.ReadImages().size();
  }
  ThrowUnless(num_in_db > 0,
              StrCat("colmap extracted no features; see ", ws,
                     on_slurm ? "/slurm/features/task_*.log"
                              : "/logs/feature_extractor.log"));
  if (num_in_db < image_names.size()) {
    HISFM_LOG_WARN("colmap read {} of {} images; see {}", num_in_db,
                   image_names.size(), ws + "/logs/feature_extractor.log");
  }
  RemoveDatabaseFiles(database);
  std::error_code ec;
  fs::rename(tmp, database, ec);
  ThrowUnless(!ec, StrCat("cannot rename ", tmp, ": ", ec.message()));
  ledger.MarkDone("features", features_fp, result.extraction_seconds, {},
                  {{"images", num_in_db},
                   {"camera_mode", CameraModeName(result.camera_mode)},
                   {"executor", options.executor}});
}

// Stage: the vocabulary tree (retrieval only): the user's, or one built
// from the collection's descriptors and kept while they are unchanged.
// Returns the tree's fingerprint ("" without retrieval).
std::string PrepareVocabTree(const PipelineRun& run,
                             const std::string& features_fp,
                             size_t num_images) {
  const FeaturePipelineOptions& options = run.options;
  FeaturePipelineResult& result = *run.result;
  StageLedger& ledger = *run.ledger;
  const std::string& ws = run.ws;
  std::string tree_fp;
  if (options.matcher != "vocab_tree") return tree_fp;
  if (!options.vocab_tree_path.empty()) {
    CheckFileReadable(options.vocab_tree_path, "vocabulary tree");
    result.vocab_tree_path =
        fs::absolute(options.vocab_tree_path).lexically_normal();
    return TextFingerprint(StrCat("given tree\n", result.vocab_tree_path, "\n",
                                  FileStamp(result.vocab_tree_path)));
  }
  result.vocab_tree_path = ws + "/vocab_tree.bin";
  const int words = VocabTreeBuildWords(options, num_images);
  const int branching = VocabTreeBuildBranching(words);
  tree_fp = TextFingerprint(StrCat("vocab_tree v1\n", features_fp, "\n", words,
                                   "\n", branching));
  if (ledger.IsDone("vocab_tree", tree_fp)) {
    HISFM_LOG_INFO("vocabulary tree: unchanged since the last run, reused");
  } else {
    ledger.Invalidate("vocab_tree");
    LogHeading(StrCat("Building a vocabulary tree of ", words,
                      " visual words from the descriptors of ", num_images,
                      " image(s) (colmap vocab_tree_builder)"));
    const std::string tmp = ws + "/vocab_tree.tmp.bin";
    std::error_code ec;
    fs::remove(tmp, ec);
    // colmap aborts if asked to sample more images than it has.
    size_t num_db_images = 0;
    {
      Database db(run.database);
      num_db_images = db.ReadImages().size();
    }
    Timer timer;
    RunColmap(options.colmap,
              {"vocab_tree_builder", "--database_path", run.database,
               "--vocab_tree_path", tmp, "--num_visual_words",
               std::to_string(words), "--branching",
               std::to_string(branching), "--num_iterations", "5",
               "--max_num_images",
               std::to_string(VocabTreeBuildImages(
                   num_db_images, MeanDescriptors(run.database)))},
              ws + "/logs/vocab_tree_builder.log");
    const double seconds = timer.ElapsedSeconds();
    fs::rename(tmp, result.vocab_tree_path, ec);
    ThrowUnless(!ec, StrCat("cannot rename ", tmp, ": ", ec.message()));
    HISFM_LOG_INFO("vocabulary tree built in {:.1f} s: {}", seconds,
                   result.vocab_tree_path);
    ledger.MarkDone("vocab_tree", tree_fp, seconds, {result.vocab_tree_path},
                    {{"words", words}});
    result.vocab_tree_built = true;
  }
  result.recorded_vocab_tree_seconds = ledger.Seconds("vocab_tree");
  return tree_fp;
}

// The Slurm matching job of `db_names`' images: blocks of pairs
// (exhaustive, sequential) or shards of query images (vocab_tree).
SlurmMatchingJob SlurmMatchingJobFor(const PipelineRun& run,
                                     const std::vector<std::string>& db_names,
                                     const std::string& features_only,
                                     const std::string& matching_fp) {
  const FeaturePipelineOptions& options = run.options;
  const size_t num_images = db_names.size();
  SlurmMatchingJob job;
  job.features_path = features_only;
  job.image_names = db_names;
  const size_t group = options.block_group_size > 0
                           ? static_cast<size_t>(options.block_group_size)
                           : PieceSize(num_images, 4);
  if (options.matcher == "exhaustive") {
    job.pair_blocks = ExhaustivePairBlocks(num_images, group);
  } else if (options.matcher == "sequential") {
    const SequentialMatchingFlags flags =
        ReadSequentialMatchingFlags(options.matcher_args);
    job.pair_blocks =
        CutPairs(SequentialPairs(num_images, flags.overlap, flags.quadratic),
                 group * group);
  } else {
    const size_t shard = options.shard_size > 0
                             ? static_cast<size_t>(options.shard_size)
                             : PieceSize(num_images, 8);
    for (size_t start = 0; start < num_images; start += shard) {
      std::vector<size_t> queries;
      for (size_t i = start; i < std::min(num_images, start + shard); ++i) {
        queries.push_back(i);
      }
      job.query_shards.push_back(std::move(queries));
    }
    job.vocab_tree_path = run.result->vocab_tree_path;
    job.num_neighbors = options.num_neighbors;
  }
  job.matcher_args = SiftMatchingArgs(options.matcher_args);
  job.fingerprint = matching_fp;
  return job;
}

// Matches the features of `tmp` (a copy of the database without matches)
// with colmap's matcher on this machine; returns the seconds it took.
double MatchLocally(const PipelineRun& run, const std::string& tmp,
                    size_t num_images) {
  const FeaturePipelineOptions& options = run.options;
  const std::string log = run.ws + "/logs/" + options.matcher + "_matcher.log";
  std::vector<std::string> args = {
      options.matcher + "_matcher", "--database_path",        tmp,
      "--SiftMatching.use_gpu",     "0",
      "--SiftMatching.num_threads", std::to_string(options.num_threads)};
  size_t total = num_images;
  ProgressLineParser parser = ParseSequentialProgress;
  if (options.matcher == "exhaustive") {
    const int block = ExhaustiveBlockSize(options, num_images);
    args.insert(args.end(),
                {"--ExhaustiveMatching.block_size", std::to_string(block)});
    const size_t blocks = (num_images + block - 1) / block;
    total = blocks * blocks;
    parser = ParseExhaustiveProgress;
  } else if (options.matcher == "vocab_tree") {
    args.insert(args.end(), {"--VocabTreeMatching.vocab_tree_path",
                             run.result->vocab_tree_path,
                             "--VocabTreeMatching.num_images",
                             std::to_string(options.num_neighbors)});
  }
  args.insert(args.end(), options.matcher_args.begin(),
              options.matcher_args.end());
  LogHeading(StrCat("Matching ", num_images, " image(s) (colmap ",
                    options.matcher, "_matcher, CPU)"));
  return RunColmapWithProgress(options.colmap, args, log,
                               options.matcher == "exhaustive"
                                   ? "Matching image blocks"
                                   : "Matching images",
                               total, parser);
}

// Stage: matching and geometric verification, on Slurm or on this machine,
// unless the ledger holds it with `matching_fp`.
void MatchFeatures(const PipelineRun& run, const std::string& matching_fp) {
  const FeaturePipelineOptions& options = run.options;
  FeaturePipelineResult& result = *run.result;
  StageLedger& ledger = *run.ledger;
  const std::string& database = run.database;
  if (ledger.IsDone("matching", matching_fp)) {
    result.matching_skipped = true;
    HISFM_LOG_INFO("matching: unchanged since the last run, skipped");
    return;
  }
  ledger.Invalidate("matching");
  std::vector<std::string> db_names;
  {
    Database db(database);
    for (const DatabaseImage& im : db.ReadImages()) {
      db_names.push_back(im.name);
    }
  }
  const size_t num_images = db_names.size();
  const std::string tmp = run.ws + "/database.matching.tmp.db";
  RemoveDatabaseFiles(tmp);
  std::error_code ec;
  if (run.OnSlurm()) {
    const std::string dir = run.ws + "/slurm/matching";
    fs::create_directories(dir, ec);
    const std::string features_only = dir + "/features.db";
    RemoveDatabaseFiles(features_only);
    fs::copy_file(database, features_only, ec);
    ThrowUnless(!ec, StrCat("cannot copy ", database, ": ", ec.message()));
    ClearMatches(features_only);
    const SlurmMatchingJob job =
        SlurmMatchingJobFor(run, db_names, features_only, matching_fp);
    Timer timer;
    result.matching_blocks =
        MatchOnSlurm(job, options.colmap, options.slurm, dir, tmp);
    result.matching_seconds = timer.ElapsedSeconds();
  } else {
    fs::copy_file(database, tmp, ec);
    ThrowUnless(!ec, StrCat("cannot copy ", database, ": ", ec.message()));
    ClearMatches(tmp);
    result.matching_seconds = MatchLocally(run, tmp, num_images);
  }
  size_t num_pairs = 0;
  {
    Database db(tmp);
    num_pairs = db.NumVerifiedPairs(1);
  }
  HISFM_LOG_INFO("{} verified image pair(s) ({:.1f} s)", num_pairs,
                 result.matching_seconds);
  fs::rename(tmp, database, ec);
  ThrowUnless(!ec, StrCat("cannot rename ", tmp, ": ", ec.message()));
  ledger.MarkDone("matching", matching_fp, result.matching_seconds, {database},
                  {{"matcher", options.matcher},
                   {"executor", options.executor},
                   {"verified_pairs", num_pairs}});
}

}  // namespace

FeaturePipelineResult RunFeaturePipeline(
    const std::string& image_path, const std::string& workspace_path,
    const FeaturePipelineOptions& options) {
  options.Check();
  FeaturePipelineResult result;
  result.scan = ScanImageFolder(image_path);
  const ImageFolderScan& scan = result.scan;
  const std::string colmap_version = CheckColmapAvailable(options.colmap);

  std::error_code ec;
  fs::create_directories(workspace_path + "/logs", ec);
  ThrowUnless(!ec, StrCat("cannot create workspace ", workspace_path, ": ",
                          ec.message()));
  const std::string ws = fs::absolute(workspace_path).lexically_normal();
  PipelineRun run{options,
                  ws,
                  fs::absolute(image_path).lexically_normal(),
                  ws + "/image_list.txt",
                  ws + "/database.db",
                  nullptr,
                  &result};

  result.scan.skipped = RecordSkippedFiles(scan.skipped, run.ws,
                                           run.images_abs);
  result.camera_mode =
      ResolveCameraMode(ParseCameraMode(options.camera_mode), scan.images);
  HISFM_LOG_INFO("{}: {} readable image(s), camera mode '{}'", image_path,
                 scan.images.size(), CameraModeName(result.camera_mode));
  const std::string images_record =
      WriteImageList(scan.images, run.images_abs, run.list_path);
  StageLedger ledger(run.ws + "/stages.json");
  run.ledger = &ledger;
  result.database_path = run.database;

  const std::string features_fp = TextFingerprint(StrCat(
      "features v1\n", colmap_version, "\n", images_record,
      CameraModeName(result.camera_mode), "\n", options.camera_model, "\n",
      JoinArgs(options.extractor_args)));
  std::vector<std::string> image_names;
  for (const ImageFileInfo& im : scan.images) image_names.push_back(im.name);
  ExtractFeatures(run, features_fp, image_names);
  result.recorded_extraction_seconds = ledger.Seconds("features");

  const std::string tree_fp =
      PrepareVocabTree(run, features_fp, image_names.size());

  std::string matcher_key = options.matcher;
  if (options.matcher == "vocab_tree") {
    matcher_key += StrCat(" ", tree_fp, " ", options.num_neighbors);
  }
  const std::string matching_fp = TextFingerprint(
      StrCat("matching v1\n", features_fp, "\n", matcher_key, "\n",
             JoinArgs(options.matcher_args)));
  result.fingerprint = matching_fp;
  MatchFeatures(run, matching_fp);
  result.recorded_matching_seconds = ledger.Seconds("matching");
  return result;
}

}  // namespace hisfm
