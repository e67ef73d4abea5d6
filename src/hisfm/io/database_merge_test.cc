#include "hisfm/io/database_merge.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <map>

#include "hisfm/io/database.h"
#include "hisfm/io/database_validation.h"
#include "hisfm/io/database_writer.h"
#include "hisfm/util/error.h"
#include "hisfm/util/test_util.h"

namespace fs = std::filesystem;

namespace hisfm {
namespace {

// Keypoints whose first x tells the image: (100 * tag + i, i).
Keypoints TaggedKeypoints(int tag, int n) {
  Keypoints k(n, 2);
  for (int i = 0; i < n; ++i) {
    k(i, 0) = static_cast<float>(100 * tag + i);
    k(i, 1) = static_cast<float>(i);
  }
  return k;
}

// A shard as one feature_extractor run over `names` writes it: image ids
// 1..n in order, one camera (of width `width`) or one per image.
void WriteShard(const std::string& path, const std::vector<std::string>& names,
                const std::vector<int>& tags, bool single_camera,
                uint64_t width) {
  DatabaseWriter w(path);
  for (size_t i = 0; i < names.size(); ++i) {
    const CameraId camera = single_camera ? 1 : static_cast<CameraId>(i + 1);
    if (!single_camera || i == 0) {
      w.WriteCamera(SimplePinholeCamera(camera, width + i, 600, 800));
    }
    w.WriteImage({static_cast<ImageId>(i + 1), names[i], camera});
    w.WriteKeypoints(static_cast<ImageId>(i + 1),
                     TaggedKeypoints(tags[i], 5 + tags[i]));
    Descriptors d(5 + tags[i], 128);
    d.setConstant(static_cast<uint8_t>(tags[i]));
    w.WriteDescriptors(static_cast<ImageId>(i + 1), d);
  }
  w.Close();
}

TEST(MergeFeatureShards, GivesTheIdsOfOneRunOverTheList) {
  TempDir tmp;
  // Shards out of order and with their own ids 1..n.
  WriteShard(tmp / "s1.db", {"c.jpg", "d.jpg"}, {3, 4}, false, 1000);
  WriteShard(tmp / "s0.db", {"a.jpg", "b.jpg"}, {1, 2}, false, 2000);
  const std::vector<std::string> names = {"a.jpg", "b.jpg", "c.jpg", "d.jpg"};
  MergeFeatureShards({tmp / "s1.db", tmp / "s0.db"}, names, tmp / "out.db");
  Database db(tmp / "out.db");
  const std::vector<DatabaseImage> images = db.ReadImages();
  ASSERT_EQ(images.size(), 4u);
  const std::vector<DatabaseCamera> cameras = db.ReadCameras();
  ASSERT_EQ(cameras.size(), 4u);
  for (size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(images[i].image_id, i + 1);
    EXPECT_EQ(images[i].name, names[i]);
    // One camera per image, numbered like the images.
    EXPECT_EQ(images[i].camera_id, i + 1);
    const Keypoints k = db.ReadKeypoints(images[i].image_id);
    ASSERT_EQ(k.rows(), static_cast<int>(6 + i));
    EXPECT_FLOAT_EQ(k(0, 0), 100.0f * (i + 1));
    const Descriptors d = db.ReadDescriptors(images[i].image_id);
    ASSERT_EQ(d.rows(), static_cast<int>(6 + i));
    EXPECT_EQ(d(0, 0), i + 1);
  }
  // a.jpg's camera came from shard s0 (width 2000), c.jpg's from s1 (1000).
  EXPECT_EQ(cameras[0].width, 2000u);
  EXPECT_EQ(cameras[1].width, 2001u);
  EXPECT_EQ(cameras[2].width, 1000u);
  EXPECT_TRUE(ValidateDatabase(tmp / "out.db").empty());
}

TEST(MergeFeatureShards, SingleCameraKeepsTheFirstImagesCamera) {
  TempDir tmp;
  WriteShard(tmp / "s0.db", {"a.jpg", "b.jpg"}, {1, 2}, true, 2000);
  WriteShard(tmp / "s1.db", {"c.jpg"}, {3}, true, 1000);
  FeatureShardMergeOptions options;
  options.single_camera = true;
  MergeFeatureShards({tmp / "s0.db", tmp / "s1.db"},
                     {"a.jpg", "b.jpg", "c.jpg"}, tmp / "out.db", options);
  Database db(tmp / "out.db");
  ASSERT_EQ(db.ReadCameras().size(), 1u);
  EXPECT_EQ(db.ReadCameras()[0].width, 2000u);
  for (const DatabaseImage& im : db.ReadImages()) EXPECT_EQ(im.camera_id, 1u);
}

TEST(MergeFeatureShards, MissingDuplicateOrUnlistedImagesAreErrors) {
  TempDir tmp;
  WriteShard(tmp / "s0.db", {"a.jpg", "b.jpg"}, {1, 2}, false, 100);
  WriteShard(tmp / "s1.db", {"b.jpg"}, {3}, false, 100);
  auto message = [&](const std::vector<std::string>& shards,
                     const std::vector<std::string>& names) {
    try {
      MergeFeatureShards(shards, names, tmp / "out.db");
    } catch (const Error& e) {
      return std::string(e.what());
    }
    return std::string();
  };
  EXPECT_NE(message({tmp / "s0.db", tmp / "s1.db"}, {"a.jpg", "b.jpg"})
                .find("b.jpg is in two shards"),
            std::string::npos);
  EXPECT_NE(message({tmp / "s0.db"}, {"a.jpg", "b.jpg", "c.jpg"})
                .find("c.jpg is in no feature shard"),
            std::string::npos);
  EXPECT_NE(message({tmp / "s0.db"}, {"a.jpg"}).find("not in the image list"),
            std::string::npos);
  // Nothing is left behind by a failed merge.
  EXPECT_FALSE(fs::exists(tmp / "out.db"));
  for (const auto& entry : fs::directory_iterator(tmp.path())) {
    EXPECT_EQ(entry.path().filename().string().find(".tmp-"),
              std::string::npos)
        << entry.path();
  }
}

TEST(MergeMatchBlocks, CollectsEveryBlocksPairsOnce) {
  TempDir tmp;
  // Features: three images in one database; blocks: copies with pairs.
  WriteShard(tmp / "features.db", {"a.jpg", "b.jpg", "c.jpg"}, {1, 2, 3},
             true, 100);
  auto block = [&](const std::string& name,
                   const std::vector<std::pair<ImagePair, int>>& pairs) {
    const std::string path = tmp / name;
    WriteShard(path, {"a.jpg", "b.jpg", "c.jpg"}, {1, 2, 3}, true, 100);
    // Reopen for writing through SQLite: DatabaseWriter only creates.
    const std::string rows = tmp / (name + ".rows.db");
    DatabaseWriter w(rows);
    for (const auto& [pair, n] : pairs) {
      std::vector<FeatureMatch> m;
      for (int i = 0; i < n; ++i) {
        m.push_back({static_cast<Point2DIdx>(i), static_cast<Point2DIdx>(i)});
      }
      w.WriteMatches(pair, m);
      TwoViewGeometry g;
      g.pair = pair;
      g.config = 2;
      g.inlier_matches = m;
      w.WriteTwoViewGeometry(g);
    }
    w.Close();
    EXPECT_EQ(RunShell("sqlite3 " + path + " \"ATTACH '" + rows +
                       "' AS r; INSERT INTO matches SELECT * FROM "
                       "r.matches; INSERT INTO two_view_geometries SELECT * "
                       "FROM r.two_view_geometries;\""),
              0);
    return path;
  };
  const std::string b0 = block("b0.db", {{{1, 2}, 5}, {{1, 3}, 4}});
  const std::string b1 = block("b1.db", {{{2, 3}, 6}, {{1, 3}, 3}});
  const MatchBlockMergeStats stats =
      MergeMatchBlocks(tmp / "features.db", {b0, b1}, tmp / "out.db");
  EXPECT_EQ(stats.verified_pairs, 3u);
  EXPECT_EQ(stats.matched_pairs, 3u);
  EXPECT_EQ(stats.duplicate_pairs, 1u);
  Database db(tmp / "out.db");
  EXPECT_EQ(db.ReadImages().size(), 3u);
  EXPECT_EQ(db.ReadKeypoints(2).rows(), 7);
  EXPECT_EQ(db.ReadDescriptors(3).rows(), 8);
  std::map<std::pair<ImageId, ImageId>, uint32_t> inliers;
  for (const VerifiedPair& p : db.ReadVerifiedPairs(1)) {
    inliers[{p.pair.image_id1, p.pair.image_id2}] = p.num_inliers;
  }
  EXPECT_EQ(inliers.size(), 3u);
  EXPECT_EQ((inliers[{1, 2}]), 5u);
  EXPECT_EQ((inliers[{2, 3}]), 6u);
  // The first block's row of a pair in two blocks.
  EXPECT_EQ((inliers[{1, 3}]), 4u);
  EXPECT_TRUE(ValidateDatabase(tmp / "out.db").empty());

  // A block of another image set is refused.
  WriteShard(tmp / "other.db", {"a.jpg", "x.jpg", "c.jpg"}, {1, 2, 3}, true,
             100);
  try {
    MergeMatchBlocks(tmp / "features.db", {tmp / "other.db"}, tmp / "o2.db");
    FAIL() << "a block with other images was merged";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("other images"), std::string::npos);
  }
  EXPECT_FALSE(fs::exists(tmp / "o2.db"));
}

}  // namespace
}  // namespace hisfm
