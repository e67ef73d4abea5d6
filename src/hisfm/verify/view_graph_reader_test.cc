#include "hisfm/verify/view_graph_reader.h"

#include <gtest/gtest.h>

#include <vector>

#include "hisfm/io/database_writer.h"
#include "hisfm/util/test_util.h"

namespace hisfm {
namespace {

// Four images; pairs (1, 2) with 12 inliers, (2, 3) with 5, (1, 3) with 30.
// Image 4 has no pair.
void WriteDatabase(const std::string& path) {
  DatabaseWriter writer(path);
  writer.WriteCamera(SimplePinholeCamera(1, 100, 100, 100));
  for (ImageId id = 1; id <= 4; ++id) {
    writer.WriteImage({id, "im" + std::to_string(id), 1});
    Keypoints k(40, 2);
    for (int r = 0; r < 40; ++r) k.row(r) << 2.0f * r, 3.0f * r;
    writer.WriteKeypoints(id, k);
  }
  auto write = [&](ImageId a, ImageId b, uint32_t n) {
    TwoViewGeometry g;
    g.pair = ImagePair(a, b);
    g.config = static_cast<int>(TwoViewConfig::kCalibrated);
    for (uint32_t i = 0; i < n; ++i) g.inlier_matches.push_back({i, i});
    writer.WriteTwoViewGeometry(g);
  };
  write(1, 2, 12);
  write(2, 3, 5);
  write(3, 1, 30);
  writer.Close();
}

TEST(ReadViewGraph, EveryImageAndThePairsWithEnoughInliers) {
  TempDir dir("hisfm-view-graph-reader");
  WriteDatabase(dir / "database.db");
  const Database db(dir / "database.db");

  const ViewGraph all = ReadViewGraph(db, 1);
  EXPECT_EQ(all.Images(), (std::vector<ImageId>{1, 2, 3, 4}));
  ASSERT_EQ(all.NumEdges(), 3u);
  EXPECT_EQ(all.Weight(1, 2), 12u);
  EXPECT_EQ(all.Weight(3, 2), 5u);
  EXPECT_EQ(all.Weight(1, 3), 30u);
  EXPECT_TRUE(all.IncidentEdges(all.IndexOf(4)).empty());

  // The threshold drops (2, 3) but keeps its images and the isolated one.
  const ViewGraph strong = ReadViewGraph(db, 10);
  EXPECT_EQ(strong.NumImages(), 4u);
  ASSERT_EQ(strong.NumEdges(), 2u);
  EXPECT_EQ(strong.Weight(2, 3), 0u);
  EXPECT_EQ(strong.Edges()[0].pair, ImagePair(1, 2));
  EXPECT_EQ(strong.Edges()[1].pair, ImagePair(1, 3));
  EXPECT_EQ(ReadViewGraph(db, 31).NumEdges(), 0u);
}

}  // namespace
}  // namespace hisfm
