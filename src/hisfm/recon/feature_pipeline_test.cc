#include "hisfm/recon/feature_pipeline.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include "hisfm/io/database.h"
#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"
#include "hisfm/util/test_util.h"

namespace fs = std::filesystem;

namespace hisfm {
namespace {

void WriteBytes(const std::string& path, const std::vector<uint8_t>& bytes) {
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
}

// A JPEG header: SOI, an APP0 segment, then SOF0 with the size.
std::vector<uint8_t> JpegBytes(int width, int height) {
  std::vector<uint8_t> b = {0xFF, 0xD8, 0xFF, 0xE0, 0x00, 0x10, 'J', 'F',
                            'I',  'F',  0,    1,    1,    0,    0,    1,
                            0,    1,    0,    0};
  const std::vector<uint8_t> sof = {
      0xFF, 0xC0, 0x00, 0x11, 8,
      static_cast<uint8_t>(height >> 8), static_cast<uint8_t>(height & 0xFF),
      static_cast<uint8_t>(width >> 8), static_cast<uint8_t>(width & 0xFF),
      3, 1, 0x22, 0, 2, 0x11, 1, 3, 0x11, 1};
  b.insert(b.end(), sof.begin(), sof.end());
  return b;
}

std::vector<uint8_t> PngBytes(uint32_t width, uint32_t height) {
  std::vector<uint8_t> b = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n',
                            0,    0,   0,   13,  'I',  'H',  'D',  'R'};
  for (uint32_t v : {width, height}) {
    for (int s = 24; s >= 0; s -= 8) b.push_back((v >> s) & 0xFF);
  }
  b.insert(b.end(), {8, 2, 0, 0, 0, 0, 0, 0, 0});
  return b;
}

std::vector<uint8_t> BmpBytes(int32_t width, int32_t height) {
  std::vector<uint8_t> b(54, 0);
  b[0] = 'B';
  b[1] = 'M';
  b[14] = 40;
  for (int i = 0; i < 4; ++i) {
    b[18 + i] = (static_cast<uint32_t>(width) >> (8 * i)) & 0xFF;
    b[22 + i] = (static_cast<uint32_t>(height) >> (8 * i)) & 0xFF;
  }
  return b;
}

// Big-endian TIFF with ImageWidth as SHORT and ImageLength as LONG.
std::vector<uint8_t> TiffBytes(uint16_t width, uint32_t height) {
  std::vector<uint8_t> b = {'M', 'M', 0, 42, 0, 0, 0, 8, 0, 2};
  const std::vector<uint8_t> e1 = {1, 0, 0, 3, 0, 0, 0, 1,
                                   static_cast<uint8_t>(width >> 8),
                                   static_cast<uint8_t>(width & 0xFF), 0, 0};
  const std::vector<uint8_t> e2 = {
      1, 1, 0, 4, 0, 0, 0, 1,
      static_cast<uint8_t>(height >> 24), static_cast<uint8_t>(height >> 16),
      static_cast<uint8_t>(height >> 8), static_cast<uint8_t>(height & 0xFF)};
  b.insert(b.end(), e1.begin(), e1.end());
  b.insert(b.end(), e2.begin(), e2.end());
  b.insert(b.end(), {0, 0, 0, 0});
  return b;
}

TEST(ImageHeader, ReadsSizesOfAllFormats) {
  TempDir tmp;
  struct Case {
    std::string name;
    std::vector<uint8_t> bytes;
    ImageFormat format;
    int width, height;
  };
  const std::vector<Case> cases = {
      {"a.jpg", JpegBytes(1067, 800), ImageFormat::kJpeg, 1067, 800},
      {"b.png", PngBytes(640, 480), ImageFormat::kPng, 640, 480},
      {"c.bmp", BmpBytes(33, -17), ImageFormat::kBmp, 33, 17},
      {"d.tif", TiffBytes(300, 200), ImageFormat::kTiff, 300, 200}};
  for (const Case& c : cases) {
    WriteBytes(tmp / c.name, c.bytes);
    ImageFileInfo info;
    std::string reason;
    ASSERT_TRUE(ReadImageHeader(tmp / c.name, &info, &reason))
        << c.name << ": " << reason;
    EXPECT_EQ(info.format, c.format) << c.name;
    EXPECT_EQ(info.width, c.width) << c.name;
    EXPECT_EQ(info.height, c.height) << c.name;
  }
}

TEST(ImageHeader, RejectsNonImagesAndTruncatedFiles) {
  TempDir tmp;
  std::vector<uint8_t> truncated = JpegBytes(100, 100);
  truncated.resize(22);  // Cut inside the APP0 segment.
  WriteBytes(tmp / "trunc.jpg", truncated);
  WriteBytes(tmp / "text.jpg", {'h', 'e', 'l', 'l', 'o', ' ', 'w', 'o', 'r',
                                'l', 'd', '\n'});
  WriteBytes(tmp / "empty.png", {});
  WriteBytes(tmp / "zero.png", PngBytes(0, 10));
  for (const char* name : {"trunc.jpg", "text.jpg", "empty.png", "zero.png",
                           "missing.jpg"}) {
    ImageFileInfo info;
    std::string reason;
    EXPECT_FALSE(ReadImageHeader(tmp / name, &info, &reason)) << name;
    EXPECT_FALSE(reason.empty()) << name;
  }
}

TEST(ImageHeader, ReadsRealPhoto) {
  const std::string dir = SharedDataPath("yan2017/books", "images");
  if (dir.empty()) GTEST_SKIP() << "shared data not found (HISFM_DATA_DIR)";
  ImageFileInfo info;
  std::string reason;
  ASSERT_TRUE(ReadImageHeader(dir + "/0000.jpg", &info, &reason)) << reason;
  EXPECT_EQ(info.format, ImageFormat::kJpeg);
  EXPECT_EQ(info.width, 1067);
  EXPECT_EQ(info.height, 800);
}

TEST(ScanImageFolder, ListsReadableImagesAndSkipsTheRest) {
  TempDir tmp;
  fs::create_directories(tmp / "img/sub");
  fs::create_directories(tmp / "img/.hidden");
  WriteBytes(tmp / "img/b.jpg", JpegBytes(10, 20));
  WriteBytes(tmp / "img/sub/a.png", PngBytes(10, 20));
  WriteBytes(tmp / "img/broken.jpg", {1, 2, 3, 4, 5, 6, 7, 8, 9});
  WriteBytes(tmp / "img/notes.txt", {'x', 'y', 'z', 'w', 'v', 'u', 't', 's'});
  WriteBytes(tmp / "img/.DS_Store", {0, 0, 0});
  WriteBytes(tmp / "img/.hidden/c.jpg", JpegBytes(10, 20));
  const ImageFolderScan scan = ScanImageFolder(tmp / "img");
  ASSERT_EQ(scan.images.size(), 2u);
  EXPECT_EQ(scan.images[0].name, "b.jpg");
  EXPECT_EQ(scan.images[1].name, "sub/a.png");
  EXPECT_GT(scan.images[0].file_size, 0u);
  EXPECT_GT(scan.images[0].mtime_ns, 0);
  ASSERT_EQ(scan.skipped.size(), 2u);
  EXPECT_EQ(scan.skipped[0].name, "broken.jpg");
  EXPECT_EQ(scan.skipped[1].name, "notes.txt");
  EXPECT_EQ(ResolveCameraMode(CameraMode::kAuto, scan.images),
            CameraMode::kSingle);
}

TEST(ScanImageFolder, MissingEmptyOrImagelessFolderIsAnError) {
  TempDir tmp;
  fs::create_directories(tmp / "empty");
  fs::create_directories(tmp / "junk");
  WriteBytes(tmp / "junk/a.jpg", {'n', 'o', 't', ' ', 'j', 'p', 'e', 'g'});
  for (const std::string& dir :
       {tmp / "missing", tmp / "empty", tmp / "junk"}) {
    try {
      ScanImageFolder(dir);
      ADD_FAILURE() << "no error for " << dir;
    } catch (const Error& e) {
      const std::string message = e.what();
      EXPECT_EQ(message.find('\n'), std::string::npos);
      EXPECT_NE(message.find(dir), std::string::npos) << message;
    }
  }
}

TEST(CameraMode, ParsesAndResolves) {
  EXPECT_EQ(ParseCameraMode("single"), CameraMode::kSingle);
  EXPECT_EQ(ParseCameraMode("per_image"), CameraMode::kPerImage);
  EXPECT_EQ(ParseCameraMode("auto"), CameraMode::kAuto);
  EXPECT_THROW(ParseCameraMode("one"), Error);
  std::vector<ImageFileInfo> images(3);
  for (ImageFileInfo& im : images) {
    im.width = 1067;
    im.height = 800;
  }
  EXPECT_EQ(ResolveCameraMode(CameraMode::kAuto, images), CameraMode::kSingle);
  std::swap(images[1].width, images[1].height);
  EXPECT_EQ(ResolveCameraMode(CameraMode::kAuto, images),
            CameraMode::kPerImage);
  EXPECT_EQ(ResolveCameraMode(CameraMode::kSingle, images),
            CameraMode::kSingle);
}

TEST(ExhaustiveBlockSize, GivesAboutFourBlocksWithinColmapsRange) {
  FeaturePipelineOptions options;
  EXPECT_EQ(ExhaustiveBlockSize(options, 3), 5);
  EXPECT_EQ(ExhaustiveBlockSize(options, 21), 6);
  EXPECT_EQ(ExhaustiveBlockSize(options, 64), 16);
  EXPECT_EQ(ExhaustiveBlockSize(options, 1000), 50);
  options.exhaustive_block_size = 7;
  EXPECT_EQ(ExhaustiveBlockSize(options, 1000), 7);
}

TEST(ProgressParsers, ReadColmapLines) {
  size_t done = 0, total = 0;
  EXPECT_TRUE(ParseExtractionProgress("Processed file [3/21]", &done, &total));
  EXPECT_EQ(done, 3u);
  EXPECT_EQ(total, 21u);
  EXPECT_FALSE(ParseExtractionProgress("  Name:  0001.jpg", &done, &total));
  EXPECT_TRUE(ParseExhaustiveProgress("Matching block [2/4, 3/4] in 1.2s",
                                      &done, &total));
  EXPECT_EQ(done, 7u);
  EXPECT_EQ(total, 16u);
  EXPECT_TRUE(
      ParseSequentialProgress("Matching image [20/21] in 0.403s", &done, &total));
  EXPECT_EQ(done, 20u);
  EXPECT_EQ(total, 21u);
  total = 64;
  EXPECT_TRUE(ParseMapperProgress("Registering image #38 (12)", &done, &total));
  EXPECT_EQ(done, 12u);
  EXPECT_EQ(total, 64u);
  EXPECT_FALSE(ParseMapperProgress("Bundle adjustment report", &done, &total));
  // COLMAP 3.12 and later.
  EXPECT_TRUE(ParseMapperProgress(
      "I20260301 12:00:00.1 incremental_pipeline.cc:531] Registering image "
      "#38 (num_reg_frames=12)",
      &done, &total));
  EXPECT_EQ(done, 13u);
  // COLMAP 3.13 and later.
  EXPECT_TRUE(ParseExhaustiveProgress("Processing block [2/4, 3/4]", &done,
                                      &total));
  EXPECT_EQ(done, 7u);
  EXPECT_EQ(total, 16u);
  EXPECT_TRUE(
      ParseSequentialProgress("Processing image [5/21]", &done, &total));
  EXPECT_EQ(done, 5u);
  EXPECT_EQ(total, 21u);
}

TEST(ColmapLogFollower, FollowsAppendedLinesOnly) {
  TempDir tmp;
  const std::string log = tmp / "log.txt";
  { std::ofstream(log) << "Processed file [9/10]\n"; }  // Before: ignored.
  ColmapLogFollower follower(log, "Test", 4, ParseExtractionProgress, 0.01);
  {
    std::ofstream out(log, std::ios::app);
    out << "Processed file [1/4]\n  Name: x\nProcessed file [2/4]\nProcessed f";
  }
  const auto deadline =
      std::chrono::steady_clock::now() + std::chrono::seconds(5);
  while (follower.Done() != 2 && std::chrono::steady_clock::now() < deadline) {
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  EXPECT_EQ(follower.Done(), 2u);
  {
    std::ofstream out(log, std::ios::app);
    out << "ile [3/4]\n";
  }
  follower.Stop();
  EXPECT_EQ(follower.Done(), 3u);
}

TEST(StageLedger, RecordsFingerprintsAndDetectsChangedOutputs) {
  TempDir tmp;
  const std::string out = tmp / "out.txt";
  WriteFileAtomically(out, "v1");
  {
    StageLedger ledger(tmp / "stages.json");
    EXPECT_FALSE(ledger.IsDone("a", "fp1"));
    ledger.MarkDone("a", "fp1", 2.5, {out}, {{"n", 3}});
    ledger.MarkDone("b", "fp2", 1.0, {});
    EXPECT_TRUE(ledger.IsDone("a", "fp1"));
    EXPECT_FALSE(ledger.IsDone("a", "fp2"));
  }
  StageLedger reloaded(tmp / "stages.json");
  EXPECT_TRUE(reloaded.IsDone("a", "fp1"));
  EXPECT_DOUBLE_EQ(reloaded.Seconds("a"), 2.5);
  EXPECT_EQ(reloaded.Info("a")["n"], 3);
  reloaded.Invalidate("b");
  EXPECT_FALSE(StageLedger(tmp / "stages.json").IsDone("b", "fp2"));
  WriteFileAtomically(out, "version 2");
  EXPECT_FALSE(StageLedger(tmp / "stages.json").IsDone("a", "fp1"));
  EXPECT_NE(TextFingerprint("a"), TextFingerprint("b"));
  EXPECT_EQ(TextFingerprint("abc").size(), 16u);
}

// End to end on four photos of the books scene, downscaled for speed.
TEST(RunFeaturePipeline, ExtractsMatchesAndResumes) {
  const std::string src = SharedDataPath("yan2017/books", "images");
  if (src.empty()) GTEST_SKIP() << "shared data not found (HISFM_DATA_DIR)";
  if (!ColmapAvailable()) GTEST_SKIP() << "colmap not installed";
  TempDir tmp;
  const std::string images = tmp / "images";
  fs::create_directories(images);
  for (const char* name : {"0000.jpg", "0001.jpg", "0002.jpg", "0003.jpg"}) {
    fs::copy_file(src + "/" + name, images + "/" + name);
  }
  WriteBytes(images + "/corrupt.jpg", {0xFF, 0xD8, 0xFF, 0xE0, 0, 0x10});
  FeaturePipelineOptions options;
  options.extractor_args = {"--SiftExtraction.max_image_size", "400"};
  const std::string ws = tmp / "ws";

  const FeaturePipelineResult first = RunFeaturePipeline(images, ws, options);
  EXPECT_FALSE(first.extraction_skipped);
  EXPECT_FALSE(first.matching_skipped);
  EXPECT_EQ(first.camera_mode, CameraMode::kSingle);
  ASSERT_EQ(first.scan.images.size(), 4u);
  ASSERT_EQ(first.scan.skipped.size(), 1u);
  EXPECT_EQ(first.scan.skipped[0].name, "corrupt.jpg");
  EXPECT_NE(ReadTextFile(ws + "/skipped_images.txt").find("corrupt.jpg"),
            std::string::npos);
  {
    Database db(first.database_path);
    EXPECT_EQ(db.ReadImages().size(), 4u);
    EXPECT_EQ(db.ReadCameras().size(), 1u);
    EXPECT_GE(db.NumVerifiedPairs(15), 3u);
  }
  EXPECT_FALSE(fs::exists(ws + "/database.features.tmp.db"));
  EXPECT_FALSE(fs::exists(ws + "/database.matching.tmp.db"));

  // Unchanged: both stages skipped.
  const FeaturePipelineResult second = RunFeaturePipeline(images, ws, options);
  EXPECT_TRUE(second.extraction_skipped);
  EXPECT_TRUE(second.matching_skipped);
  EXPECT_EQ(second.fingerprint, first.fingerprint);
  EXPECT_GT(second.recorded_matching_seconds, 0.0);

  // An interrupted matching stage (no record, a stale temporary database)
  // is redone on the features.
  {
    StageLedger ledger(ws + "/stages.json");
    ledger.Invalidate("matching");
    WriteBytes(ws + "/database.matching.tmp.db", {1, 2, 3});
  }
  const FeaturePipelineResult third = RunFeaturePipeline(images, ws, options);
  EXPECT_TRUE(third.extraction_skipped);
  EXPECT_FALSE(third.matching_skipped);
  EXPECT_EQ(third.fingerprint, first.fingerprint);

  // A changed matcher redoes matching only; a touched image redoes both.
  // Sequential matching of direct neighbours only: the exhaustive pairs of
  // before must be gone.
  options.matcher = "sequential";
  options.matcher_args = {"--SequentialMatching.overlap", "2",
                          "--SequentialMatching.quadratic_overlap", "0"};
  const FeaturePipelineResult fourth = RunFeaturePipeline(images, ws, options);
  EXPECT_TRUE(fourth.extraction_skipped);
  EXPECT_FALSE(fourth.matching_skipped);
  EXPECT_NE(fourth.fingerprint, first.fingerprint);
  {
    Database db(fourth.database_path);
    EXPECT_EQ(db.NumVerifiedPairs(1), 3u);
  }
  fs::last_write_time(images + "/0002.jpg",
                      fs::last_write_time(images + "/0002.jpg") +
                          std::chrono::seconds(10));
  const FeaturePipelineResult fifth = RunFeaturePipeline(images, ws, options);
  EXPECT_FALSE(fifth.extraction_skipped);
  EXPECT_FALSE(fifth.matching_skipped);
  {
    Database db(fifth.database_path);
    EXPECT_EQ(db.ReadImages().size(), 4u);
  }

  // One camera per image.
  options.camera_mode = "per_image";
  const FeaturePipelineResult sixth = RunFeaturePipeline(images, ws, options);
  EXPECT_EQ(sixth.camera_mode, CameraMode::kPerImage);
  EXPECT_FALSE(sixth.extraction_skipped);
  Database db(sixth.database_path);
  EXPECT_EQ(db.ReadCameras().size(), 4u);
  EXPECT_EQ(db.NumVerifiedPairs(1), 3u);
}

// Retrieval on six downscaled photos of books: a tree built once from the
// photos' descriptors and kept in the workspace, each photo matched with
// the photos it retrieves only.
TEST(RunFeaturePipeline, VocabTreeMatchesRetrievedPairsOnly) {
  const std::string src = SharedDataPath("yan2017/books", "images");
  if (src.empty()) GTEST_SKIP() << "shared data not found (HISFM_DATA_DIR)";
  if (!ColmapAvailable()) GTEST_SKIP() << "colmap not installed";
  TempDir tmp;
  const std::string images = tmp / "images";
  fs::create_directories(images);
  for (int i = 0; i < 6; ++i) {
    const std::string name = StrCat("000", i, ".jpg");
    fs::copy_file(src + "/" + name, images + "/" + name);
  }
  FeaturePipelineOptions options;
  options.extractor_args = {"--SiftExtraction.max_image_size", "400"};
  options.matcher = "vocab_tree";
  options.num_neighbors = 2;
  const std::string ws = tmp / "ws";
  const FeaturePipelineResult first = RunFeaturePipeline(images, ws, options);
  EXPECT_TRUE(first.vocab_tree_built);
  EXPECT_EQ(first.vocab_tree_path, ws + "/vocab_tree.bin");
  EXPECT_TRUE(fs::exists(first.vocab_tree_path));
  EXPECT_FALSE(fs::exists(ws + "/vocab_tree.tmp.bin"));
  EXPECT_NE(ReadTextFile(ws + "/logs/vocab_tree_builder.log")
                .find("--num_visual_words 512"),
            std::string::npos);
  size_t matched = 0;
  {
    Database db(first.database_path);
    // Each photo is matched with at most 2 others: at most 6 of the 15 pairs
    // (fewer when two photos retrieve each other).
    matched = db.ReadVerifiedPairs(1).size();
    EXPECT_GE(matched, 3u);
    EXPECT_LE(matched, 6u);
  }
  // More neighbours: matching again with the same tree.
  options.num_neighbors = 5;
  const FeaturePipelineResult second = RunFeaturePipeline(images, ws, options);
  EXPECT_TRUE(second.extraction_skipped);
  EXPECT_FALSE(second.vocab_tree_built);
  EXPECT_FALSE(second.matching_skipped);
  EXPECT_NE(second.fingerprint, first.fingerprint);
  {
    Database db(second.database_path);
    EXPECT_GT(db.NumVerifiedPairs(1), matched);
  }
  // A given tree is used as is (nothing is built).
  fs::copy_file(ws + "/vocab_tree.bin", tmp / "tree.bin");
  options.vocab_tree_path = tmp / "tree.bin";
  const FeaturePipelineResult third = RunFeaturePipeline(images, ws, options);
  EXPECT_FALSE(third.vocab_tree_built);
  EXPECT_EQ(third.vocab_tree_path, tmp / "tree.bin");
  EXPECT_FALSE(third.matching_skipped);
  EXPECT_EQ(VocabTreeBuildWords(FeaturePipelineOptions(), 6), 512);
  EXPECT_EQ(VocabTreeBuildWords(FeaturePipelineOptions(), 1), 256);
  EXPECT_EQ(VocabTreeBuildWords(FeaturePipelineOptions(), 100000), 65536);
  EXPECT_EQ(VocabTreeBuildImages(21, 4000.0), 21u);
  EXPECT_EQ(VocabTreeBuildImages(1000, 4000.0), 50u);
  EXPECT_EQ(VocabTreeBuildImages(1000, 0.0), 1000u);
  EXPECT_EQ(VocabTreeBuildImages(3, 1e9), 1u);
}

}  // namespace
}  // namespace hisfm
