#include "hisfm/synth/synthetic_dataset.h"

#include <gtest/gtest.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <random>

#include "hisfm/io/database.h"
#include "hisfm/io/model.h"
#include "hisfm/util/error.h"

namespace fs = std::filesystem;

namespace hisfm {
namespace {

class SyntheticDatasetTest : public ::testing::Test {
 protected:
  void SetUp() override {
    root_ = fs::temp_directory_path() /
            ("hisfm_synth_dataset_test_" + std::to_string(std::random_device()()));
    fs::create_directories(root_);
  }
  void TearDown() override {
    std::error_code ec;
    fs::remove_all(root_, ec);
  }
  std::string Path(const std::string& name) const {
    return (root_ / name).string();
  }

  fs::path root_;
};

SynthOptions Options(const std::string& scene, int num_images) {
  SynthOptions options;
  options.scene = scene;
  options.num_images = num_images;
  options.seed = 3;
  options.num_threads = 2;
  return options;
}

bool ColmapAvailable() {
  return std::system("colmap help > /dev/null 2>&1") == 0;
}

TEST_F(SyntheticDatasetTest, WritesReadableDatabaseAndGroundTruth) {
  const SynthOptions options = Options("symmetric2", 16);
  const SynthDatasetSummary summary =
      WriteSyntheticDataset(options, Path("scene"));
  ASSERT_TRUE(fs::is_directory(Path("scene/images")));
  EXPECT_TRUE(fs::is_empty(Path("scene/images")));
  EXPECT_TRUE(fs::exists(Path("scene/synth_summary.json")));

  const Database database(Path("scene/database.db"));
  const std::vector<DatabaseCamera> cameras = database.ReadCameras();
  ASSERT_EQ(cameras.size(), 1u);
  EXPECT_EQ(cameras[0].model_id, 2);  // SIMPLE_RADIAL
  EXPECT_EQ(cameras[0].width, 1024u);
  EXPECT_TRUE(cameras[0].prior_focal_length);
  const std::vector<DatabaseImage> images = database.ReadImages();
  ASSERT_EQ(images.size(), 16u);

  const Reconstruction gt = ReadModelBinary(Path("scene/ground_truth"));
  ASSERT_EQ(gt.images.size(), 16u);
  EXPECT_EQ(gt.points3D.size(), summary.num_points3D);
  size_t num_keypoints = 0;
  for (const DatabaseImage& image : images) {
    EXPECT_EQ(image.name, SynthImageName(image.image_id - 1));
    const Image& gt_image = gt.images.at(image.image_id);
    EXPECT_EQ(gt_image.name, image.name);
    const Keypoints keypoints = database.ReadKeypoints(image.image_id);
    ASSERT_EQ(static_cast<size_t>(keypoints.rows()), gt_image.points2D.size());
    for (Eigen::Index k = 0; k < keypoints.rows(); ++k) {
      EXPECT_FLOAT_EQ(keypoints(k, 0), static_cast<float>(gt_image.points2D[k].xy.x()));
      EXPECT_FLOAT_EQ(keypoints(k, 1), static_cast<float>(gt_image.points2D[k].xy.y()));
    }
    num_keypoints += keypoints.rows();
  }
  EXPECT_EQ(num_keypoints, summary.num_keypoints);

  const std::vector<VerifiedPair> verified = database.ReadVerifiedPairs(15);
  EXPECT_EQ(verified.size(), summary.num_verified_pairs);
  EXPECT_EQ(database.NumVerifiedPairs(1), summary.num_verified_pairs);
  EXPECT_GT(summary.num_doppelganger_pairs, 0u);
  size_t num_inliers = 0;
  for (const VerifiedPair& vp : verified) {
    num_inliers += vp.num_inliers;
    const TwoViewGeometry g =
        database.ReadTwoViewGeometry(vp.pair.image_id1, vp.pair.image_id2);
    EXPECT_EQ(g.config, static_cast<int>(TwoViewConfig::kCalibrated));
    EXPECT_EQ(g.inlier_matches.size(), vp.num_inliers);
    // Inliers are a subset of the raw matches.
    const std::vector<FeatureMatch> raw =
        database.ReadMatches(vp.pair.image_id1, vp.pair.image_id2);
    EXPECT_GE(raw.size(), g.inlier_matches.size());
  }
  EXPECT_EQ(num_inliers, summary.num_inlier_matches);
}

TEST_F(SyntheticDatasetTest, SameSeedSameDatabase) {
  const SynthOptions options = Options("street", 12);
  WriteSyntheticDataset(options, Path("a"));
  WriteSyntheticDataset(options, Path("b"));
  const Database a(Path("a/database.db"));
  const Database b(Path("b/database.db"));
  const std::vector<VerifiedPair> pa = a.ReadVerifiedPairs(1);
  const std::vector<VerifiedPair> pb = b.ReadVerifiedPairs(1);
  ASSERT_EQ(pa.size(), pb.size());
  ASSERT_FALSE(pa.empty());
  for (size_t i = 0; i < pa.size(); ++i) {
    EXPECT_EQ(pa[i].pair, pb[i].pair);
    EXPECT_EQ(pa[i].num_inliers, pb[i].num_inliers);
  }
  for (ImageId id = 1; id <= 12; ++id) {
    EXPECT_TRUE(a.ReadKeypoints(id) == b.ReadKeypoints(id));
  }
}

TEST_F(SyntheticDatasetTest, RefusesNonEmptyOutputFolder) {
  fs::create_directories(Path("busy"));
  std::ofstream(Path("busy/file.txt")) << "x";
  EXPECT_THROW(WriteSyntheticDataset(Options("street", 4), Path("busy")), Error);
}

TEST_F(SyntheticDatasetTest, ColmapVerificationAgreesWithDirect) {
  if (!ColmapAvailable()) GTEST_SKIP() << "colmap is not installed";
  SynthOptions options = Options("symmetric2", 10);
  const SynthDatasetSummary direct = WriteSyntheticDataset(options, Path("direct"));
  options.two_view_geometry = "colmap";
  const SynthDatasetSummary colmap = WriteSyntheticDataset(options, Path("colmap"));
  EXPECT_EQ(direct.num_matched_pairs, colmap.num_matched_pairs);
  ASSERT_GT(direct.num_verified_pairs, 10u);
  EXPECT_NEAR(static_cast<double>(colmap.num_verified_pairs),
              static_cast<double>(direct.num_verified_pairs),
              0.1 * direct.num_verified_pairs);
  EXPECT_GT(colmap.num_doppelganger_pairs, 0u);
  EXPECT_TRUE(fs::exists(Path("colmap/matches_importer.log")));
  EXPECT_FALSE(fs::exists(Path("colmap/raw_matches.txt")));
}

}  // namespace
}  // namespace hisfm
