// From a folder of photos to a matched COLMAP database, resumably:
//   1. scan the folder (every file checked: readable, a known image header);
//   2. colmap feature_extractor (CPU SIFT) on the readable images;
//   3. colmap exhaustive_matcher, sequential_matcher or vocab_tree_matcher
//      (CPU; retrieval with a vocabulary tree the user gives or one built
//      once from the collection's descriptors, cached in the workspace).
// With the Slurm executor, stages 2 and 3 run as job arrays on a shared
// filesystem (slurm_feature_stages.h) and give the same database.
// Each stage writes its database under a temporary name that is renamed into
// place when the stage completes, and records a fingerprint of its inputs in
// WORKSPACE/stages.json; a later run skips a stage whose fingerprint and
// outputs are unchanged and redoes an interrupted or changed one.
//
// Long colmap stages report progress (done/total and the time left) by
// following colmap's log while it runs: feature_extractor prints
// "Processed file [i/n]", exhaustive_matcher "Matching block [i/n, j/n]",
// sequential_matcher "Matching image [i/n]" and mapper
// "Registering image #k (n)".
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "hisfm/recon/colmap_runner.h"
#include "hisfm/recon/slurm_executor.h"

namespace hisfm {

// ---------------------------------------------------------------------------
// Image folder scan.

/// Image file formats recognised by their first bytes.
enum class ImageFormat { kUnknown, kJpeg, kPng, kTiff, kBmp };

/// Name of a format: "JPEG", "PNG", "TIFF", "BMP" or "unknown".
std::string ImageFormatName(ImageFormat format);

/// A photo that passed the header check.
struct ImageFileInfo {
  /// Path relative to the image folder, '/'-separated (COLMAP's image name).
  std::string name;
  ImageFormat format = ImageFormat::kUnknown;
  /// Size in pixels as stored in the header (EXIF orientation not applied,
  /// as COLMAP 3.8 does not apply it either).
  int width = 0;
  int height = 0;
  /// File size in bytes and modification time (ns since the epoch): the
  /// inputs of the fingerprint.
  uint64_t file_size = 0;
  int64_t mtime_ns = 0;
};

/// A file of the folder that is not a readable image.
struct SkippedImageFile {
  std::string name;
  /// Why, e.g. "cannot be opened", "not a JPEG/PNG/TIFF/BMP file",
  /// "truncated JPEG header".
  std::string reason;
};

/// The readable images of a folder (sorted by name) and the skipped files.
struct ImageFolderScan {
  std::vector<ImageFileInfo> images;
  std::vector<SkippedImageFile> skipped;
};

/// Reads the format and pixel size of the image at `path` from its header.
/// Returns false with a short reason if the file cannot be opened or is not
/// a JPEG, PNG, TIFF or BMP file with a readable size. `info->name`,
/// `file_size` and `mtime_ns` are left untouched.
bool ReadImageHeader(const std::string& path, ImageFileInfo* info,
                     std::string* reason);

/// Checks every regular file under `image_path` (recursively, not following
/// folder symlinks, like COLMAP; hidden files and folders ignored). Throws
/// hisfm::Error with one line if the folder is missing, holds no file, or
/// holds no readable image.
ImageFolderScan ScanImageFolder(const std::string& image_path);

// ---------------------------------------------------------------------------
// Options.

/// How images share cameras (intrinsics) in the database.
enum class CameraMode {
  /// One camera for all images (--ImageReader.single_camera 1).
  kSingle,
  /// One camera per image (--ImageReader.single_camera_per_image 1).
  kPerImage,
  /// kSingle if all images have the same pixel size, else kPerImage.
  kAuto,
};

/// Parses "single", "per_image" or "auto"; throws hisfm::Error otherwise.
CameraMode ParseCameraMode(const std::string& name);
std::string CameraModeName(CameraMode mode);
/// Resolves kAuto from the images' sizes; other modes are returned as is.
CameraMode ResolveCameraMode(CameraMode mode,
                             const std::vector<ImageFileInfo>& images);

struct FeaturePipelineOptions {
  /// "exhaustive" (every pair), "sequential" (neighbours in name order) or
  /// "vocab_tree" (each image with the images a vocabulary tree retrieves).
  std::string matcher = "exhaustive";
  /// vocab_tree: a vocabulary tree file in COLMAP's format; empty: one is
  /// built from the collection's own descriptors (colmap vocab_tree_builder,
  /// see VocabTreeBuildOptions) into WORKSPACE/vocab_tree.bin, once, and
  /// reused while the features are unchanged. Nothing is downloaded.
  std::string vocab_tree_path;
  /// vocab_tree: images retrieved and matched per image
  /// (--VocabTreeMatching.num_images).
  int num_neighbors = 20;
  /// vocab_tree with a built tree: visual words; 0 picks one from the number
  /// of images (see VocabTreeBuildWords).
  int vocab_tree_num_words = 0;
  /// "local" (colmap on this machine) or "slurm" (job arrays, see
  /// slurm_feature_stages.h).
  std::string executor = "local";
  /// slurm: images per feature-extraction shard; 0 gives about 8 shards.
  int shard_size = 0;
  /// slurm: images per group of the exhaustive pair blocks (a block pairs
  /// two groups); 0 gives about 4 groups (10 blocks). Sequential pairs are
  /// cut into blocks of group_size^2 pairs, retrieval queries into shards of
  /// shard_size images.
  int block_group_size = 0;
  /// slurm: the cluster's commands and each task's resources and retries.
  SlurmOptions slurm;
  /// "single", "per_image" or "auto", see CameraMode.
  std::string camera_mode = "auto";
  /// COLMAP camera model of the new cameras (--ImageReader.camera_model).
  std::string camera_model = "SIMPLE_RADIAL";
  /// Threads of extraction and matching (-1: all cores).
  int num_threads = -1;
  /// --ExhaustiveMatching.block_size; 0 picks one giving about 4 blocks per
  /// side (at least 5 images, at most COLMAP's default 50) so that progress
  /// can be reported; the set of matched pairs does not depend on it.
  int exhaustive_block_size = 0;
  /// Extra arguments for colmap feature_extractor (e.g.
  /// "--SiftExtraction.max_num_features", "4096").
  std::vector<std::string> extractor_args;
  /// Extra arguments for the colmap matcher.
  std::vector<std::string> matcher_args;
  /// The colmap executable.
  ColmapRunnerOptions colmap;

  void Check() const;
};

/// The exhaustive block size used for `num_images` (see
/// FeaturePipelineOptions::exhaustive_block_size).
int ExhaustiveBlockSize(const FeaturePipelineOptions& options,
                        size_t num_images);

/// Visual words of a vocabulary tree built for `num_images` images when
/// FeaturePipelineOptions::vocab_tree_num_words is 0: 64 per image, rounded
/// to a power of two within [256, 65536]. A tree far larger than the
/// collection's descriptors (a few thousand per photo) leaves most words
/// with one descriptor and retrieval degrades to chance; COLMAP's published
/// trees have 32K words for 1,000-10,000 images.
int VocabTreeBuildWords(const FeaturePipelineOptions& options,
                        size_t num_images);

/// Branching factor of a built tree with `num_words` words: 16 below 4,096
/// words, else 32 (colmap's default 256 makes building a tree for a few
/// hundred thousand descriptors take minutes).
int VocabTreeBuildBranching(int num_words);

/// Images sampled to build a tree (colmap vocab_tree_builder
/// --max_num_images) for `num_images` images with `mean_descriptors`
/// descriptors each: about 200,000 descriptors in all (within [1,
/// num_images]; all images if the mean is unknown). Building clusters
/// every sampled descriptor (minutes for a few hundred thousand on two
/// cores), so a large collection's tree comes from a sample of its images.
size_t VocabTreeBuildImages(size_t num_images, double mean_descriptors);

// ---------------------------------------------------------------------------
// Progress from colmap's log.

/// Parses one log line; returns true and sets *done and *total (total may
/// stay 0 to keep the caller's) if the line reports progress.
using ProgressLineParser =
    std::function<bool(const std::string& line, size_t* done, size_t* total)>;

/// "Processed file [i/n]" -> i, n.
bool ParseExtractionProgress(const std::string& line, size_t* done,
                             size_t* total);
/// "Matching block [i/n, j/n]" ("Processing block" from COLMAP 3.13) ->
/// (i - 1) n + j, n * n.
bool ParseExhaustiveProgress(const std::string& line, size_t* done,
                             size_t* total);
/// "Matching image [i/n]" ("Processing image" from COLMAP 3.13) -> i, n.
bool ParseSequentialProgress(const std::string& line, size_t* done,
                             size_t* total);
/// "Registering image #k (n)" -> n registered images, "Registering image #k
/// (num_reg_frames=n)" (COLMAP 3.12 and later) -> n + 1 (total unchanged).
bool ParseMapperProgress(const std::string& line, size_t* done,
                         size_t* total);

/// Follows a growing log file in a background thread and reports the
/// progress its lines carry through hisfm::ProgressReporter (one updating
/// line on a terminal, plain lines every few seconds otherwise). Lines
/// already in the file when it starts are ignored; if the file is replaced
/// or truncated it is read again from the start.
class ColmapLogFollower {
 public:
  /// `what` names the stage ("Extracting features"); `total` is the expected
  /// number of items (replaced by the total a parsed line carries).
  ColmapLogFollower(std::string log_path, std::string what, size_t total,
                    ProgressLineParser parser, double poll_seconds = 0.25);
  /// Stops following (see Stop()).
  ~ColmapLogFollower();
  ColmapLogFollower(const ColmapLogFollower&) = delete;
  ColmapLogFollower& operator=(const ColmapLogFollower&) = delete;

  /// Reads what is left of the log, stops the thread and prints the final
  /// line: "what: total/total done in S s" if everything was reported, else
  /// "what: done/total in S s". Idempotent.
  void Stop();
  /// Last reported number of finished items.
  size_t Done() const { return done_.load(); }

 private:
  void Run();
  // Reads new complete lines; returns false if nothing new was read.
  bool Poll();

  struct State;
  std::unique_ptr<State> state_;
  std::atomic<size_t> done_{0};
  std::atomic<bool> stop_{false};
  std::thread thread_;
};

/// RunColmap while following `log_path` with `parser` (see
/// ColmapLogFollower). Returns the wall time in seconds.
double RunColmapWithProgress(const ColmapRunnerOptions& options,
                             const std::vector<std::string>& args,
                             const std::string& log_path,
                             const std::string& what, size_t total,
                             const ProgressLineParser& parser);

// ---------------------------------------------------------------------------
// Resumable stages.

/// 64-bit FNV-1a of a text as 16 hex digits.
std::string TextFingerprint(const std::string& text);

/// The record of finished stages of a workspace, kept in a JSON file
/// (WORKSPACE/stages.json):
///   {"stages": {"<name>": {"fingerprint": "...", "seconds": s,
///    "finished": "2024-01-01T12:00:00", "outputs": {"<path>": "size:mtime"},
///    "info": {...}}}}
/// Every change is written through a temporary file and a rename.
class StageLedger {
 public:
  /// Loads `path` if it exists (an unreadable file counts as empty).
  explicit StageLedger(std::string path);

  /// True if `stage` finished with this input fingerprint and every output
  /// it recorded still has the size and modification time it had then.
  bool IsDone(const std::string& stage, const std::string& fingerprint) const;
  /// Records that `stage` finished: its input fingerprint, wall time, output
  /// files (stat-ed now) and free-form `info`. Saves the file.
  void MarkDone(const std::string& stage, const std::string& fingerprint,
                double seconds, const std::vector<std::string>& outputs,
                const nlohmann::json& info = nlohmann::json::object());
  /// Forgets `stage` (saves the file).
  void Invalidate(const std::string& stage);
  /// Seconds recorded for a finished stage (0 if none).
  double Seconds(const std::string& stage) const;
  /// The `info` recorded for a finished stage (null if none).
  nlohmann::json Info(const std::string& stage) const;
  /// The whole record.
  const nlohmann::json& Json() const { return json_; }

 private:
  void Save() const;
  std::string path_;
  nlohmann::json json_;
};

// ---------------------------------------------------------------------------
// The pipeline.

/// What RunFeaturePipeline did.
struct FeaturePipelineResult {
  ImageFolderScan scan;
  /// The resolved camera mode.
  CameraMode camera_mode = CameraMode::kSingle;
  /// WORKSPACE/database.db.
  std::string database_path;
  /// Wall time of each stage in this run (0 if skipped) and as recorded
  /// when it last ran.
  double extraction_seconds = 0.0;
  double matching_seconds = 0.0;
  double recorded_extraction_seconds = 0.0;
  double recorded_matching_seconds = 0.0;
  bool extraction_skipped = false;
  bool matching_skipped = false;
  /// vocab_tree: the tree used, whether it was built in this run and the
  /// time of building it (this run or as recorded).
  std::string vocab_tree_path;
  bool vocab_tree_built = false;
  double recorded_vocab_tree_seconds = 0.0;
  /// slurm: shards and blocks of this configuration.
  size_t feature_shards = 0;
  size_t matching_blocks = 0;
  /// Fingerprint of the matched database's inputs; later stages include it
  /// in theirs.
  std::string fingerprint;
};

/// Runs stages 1-3 into `workspace_path` (created if missing): the image
/// list WORKSPACE/image_list.txt, WORKSPACE/database.db, the ledger
/// WORKSPACE/stages.json, colmap logs in WORKSPACE/logs/, a built
/// vocabulary tree WORKSPACE/vocab_tree.bin, the Slurm tasks in
/// WORKSPACE/slurm/. Skipped files are
/// logged and listed in WORKSPACE/skipped_images.txt. Throws hisfm::Error on
/// an empty or missing folder, a missing colmap or a failing colmap call.
FeaturePipelineResult RunFeaturePipeline(const std::string& image_path,
                                         const std::string& workspace_path,
                                         const FeaturePipelineOptions& options);

}  // namespace hisfm
