#include "hisfm/synth/synthetic_dataset.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <set>

#include "hisfm/io/database.h"
#include "hisfm/io/model.h"
#include "hisfm/synth/scene_families.h"
#include "hisfm/util/error.h"
#include "hisfm/util/test_util.h"

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

SynthOptions RandomFamily(const std::string& scene, int num_images,
                          uint32_t seed) {
  SynthOptions options = Options(scene, num_images);
  options.seed = seed;
  options.family.randomize = true;
  return options;
}

// pair_labels.txt by image-name pair.
std::map<std::pair<std::string, std::string>, PairLabel> PairLabelsByNames(
    const std::string& path) {
  std::map<std::pair<std::string, std::string>, PairLabel> labels;
  for (PairLabel& l : ReadPairLabels(path)) {
    labels[{l.name1, l.name2}] = std::move(l);
  }
  return labels;
}

TEST_F(SyntheticDatasetTest, FamilyOutputIsAFunctionOfFamilySizeAndSeed) {
  const SynthOptions options = RandomFamily("facade_street", 12, 5);
  WriteSyntheticDataset(options, Path("a"));
  WriteSyntheticDataset(options, Path("b"));
  WriteSyntheticDataset(RandomFamily("facade_street", 12, 6), Path("c"));
  for (const std::string file : {"database.db", "pair_labels.txt",
                                 "ground_truth/images.bin",
                                 "ground_truth/points3D.bin"}) {
    EXPECT_EQ(FileFingerprint(Path("a/" + file)), FileFingerprint(Path("b/" + file)))
        << file;
    EXPECT_NE(FileFingerprint(Path("a/" + file)), FileFingerprint(Path("c/" + file)))
        << file;
  }
  // The drawn parameters are in the summary.
  std::ifstream in(Path("a/synth_summary.json"));
  const nlohmann::json json = nlohmann::json::parse(in);
  const SynthFamilyOptions drawn = ResolveFamilyOptions(options);
  EXPECT_EQ(json.at("family").at("period").get<double>(), drawn.period);
  EXPECT_EQ(json.at("family").at("camera_spacing").get<double>(),
            drawn.camera_spacing);
  EXPECT_EQ(json.at("family").at("relief_depth").get<double>(), drawn.relief_depth);
  EXPECT_EQ(json.at("family").at("clutter_density").get<double>(),
            drawn.clutter_density);
  EXPECT_EQ(json.at("family").at("facade_distance").get<double>(),
            drawn.facade_distance);
  EXPECT_GT(json.at("observed_clutter_ratio").get<double>(), 0.0);
}

TEST_F(SyntheticDatasetTest, MalformedPairLabelsAreRefused) {
  const auto write = [&](const std::string& text) {
    std::ofstream(Path("labels.txt")) << text;
    return Path("labels.txt");
  };
  const auto labels = ReadPairLabels(
      write("# NAME1 NAME2 INLIERS TRUE DOPPELGANGER RANDOM\na b 5 1 3 1\n"));
  ASSERT_EQ(labels.size(), 1u);
  EXPECT_EQ(labels[0].name2, "b");
  EXPECT_EQ(labels[0].num_doppelganger, 3u);
  EXPECT_TRUE(labels[0].IsDoppelganger());
  EXPECT_THROW(ReadPairLabels(write("a b 5 1 3\n")), Error);
  EXPECT_THROW(ReadPairLabels(write("a b 6 1 3 1\n")), Error);
  EXPECT_THROW(ReadPairLabels(write("a b 5 1 3 1 x\n")), Error);
  EXPECT_THROW(ReadPairLabels(write("a b 5 -1 5 1\n")), Error);
  EXPECT_THROW(ReadPairLabels(Path("missing.txt")), Error);
}

TEST_F(SyntheticDatasetTest, PairLabelsDescribeTheInliers) {
  const SynthDatasetSummary summary =
      WriteSyntheticDataset(RandomFamily("block_loop", 24, 2), Path("scene"));
  const auto labels = PairLabelsByNames(Path("scene/pair_labels.txt"));
  ASSERT_EQ(labels.size(), summary.num_verified_pairs);
  const Database database(Path("scene/database.db"));
  const Reconstruction gt = ReadModelBinary(Path("scene/ground_truth"));
  std::map<ImageId, std::string> names;
  for (const DatabaseImage& image : database.ReadImages()) {
    names[image.image_id] = image.name;
  }
  size_t doppelganger_pairs = 0, mixed_pairs = 0;
  for (const VerifiedPair& vp : database.ReadVerifiedPairs(15)) {
    const auto it = labels.find({names.at(vp.pair.image_id1), names.at(vp.pair.image_id2)});
    ASSERT_NE(it, labels.end());
    const PairLabel& l = it->second;
    EXPECT_EQ(l.num_inliers, vp.num_inliers);
    // A true inlier observes one ground-truth point in both images.
    const TwoViewGeometry g =
        database.ReadTwoViewGeometry(vp.pair.image_id1, vp.pair.image_id2);
    const Image& image1 = gt.images.at(vp.pair.image_id1);
    const Image& image2 = gt.images.at(vp.pair.image_id2);
    size_t same_point = 0;
    for (const FeatureMatch& m : g.inlier_matches) {
      const Point3DId p1 = image1.points2D.at(m.idx1).point3D_id;
      if (p1 != kInvalidPoint3DId && p1 == image2.points2D.at(m.idx2).point3D_id) {
        ++same_point;
      }
    }
    EXPECT_EQ(same_point, l.num_true);
    if (l.IsDoppelganger()) ++doppelganger_pairs;
    if (l.num_true > 0 && l.num_doppelganger > 0) ++mixed_pairs;
  }
  EXPECT_EQ(doppelganger_pairs, summary.num_doppelganger_pairs);
  EXPECT_GT(doppelganger_pairs, 0u);
  EXPECT_GT(mixed_pairs, 0u);
}

// Median Jaccard index of the inlier sets of pairs verified in both.
double MedianInlierAgreement(const std::string& database_a,
                             const std::string& database_b) {
  const Database a(database_a), b(database_b);
  std::vector<double> agreement;
  for (const VerifiedPair& vp : a.ReadVerifiedPairs(15)) {
    const TwoViewGeometry ga = a.ReadTwoViewGeometry(vp.pair.image_id1, vp.pair.image_id2);
    const TwoViewGeometry gb = b.ReadTwoViewGeometry(vp.pair.image_id1, vp.pair.image_id2);
    std::set<std::pair<uint32_t, uint32_t>> sa, sb, both;
    for (const FeatureMatch& m : ga.inlier_matches) sa.insert({m.idx1, m.idx2});
    for (const FeatureMatch& m : gb.inlier_matches) sb.insert({m.idx1, m.idx2});
    std::set_intersection(sa.begin(), sa.end(), sb.begin(), sb.end(),
                          std::inserter(both, both.begin()));
    const size_t either = sa.size() + sb.size() - both.size();
    agreement.push_back(either == 0 ? 1.0 : static_cast<double>(both.size()) / either);
  }
  if (agreement.empty()) return 0.0;
  std::sort(agreement.begin(), agreement.end());
  return agreement[agreement.size() / 2];
}

TEST_F(SyntheticDatasetTest, FamilyDirectVerificationAgreesWithColmap) {
  if (!ColmapAvailable()) GTEST_SKIP() << "colmap is not installed";
  // COLMAP's RANSAC keeps the wrong matches of a planar facade that lie on
  // a true pair's epipolar lines; the direct mode must keep the same ones.
  SynthOptions options = Options("facade_street", 12);
  const SynthDatasetSummary direct = WriteSyntheticDataset(options, Path("direct"));
  options.two_view_geometry = "colmap";
  const SynthDatasetSummary colmap = WriteSyntheticDataset(options, Path("colmap"));
  EXPECT_EQ(direct.num_matched_pairs, colmap.num_matched_pairs);
  EXPECT_NEAR(static_cast<double>(colmap.num_verified_pairs),
              static_cast<double>(direct.num_verified_pairs),
              0.05 * direct.num_verified_pairs);
  EXPECT_GT(MedianInlierAgreement(Path("direct/database.db"),
                                  Path("colmap/database.db")),
            0.95);
  size_t mixed = 0;
  for (const auto& [names, l] : PairLabelsByNames(Path("colmap/pair_labels.txt"))) {
    if (l.num_true > l.num_doppelganger && l.num_doppelganger > 0) ++mixed;
  }
  EXPECT_GT(mixed, 5u);
}

}  // namespace
}  // namespace hisfm
