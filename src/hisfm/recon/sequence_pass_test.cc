#include "hisfm/recon/sequence_pass.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <random>

#include "hisfm/io/database_writer.h"
#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"
#include "hisfm/util/test_util.h"
#include "hisfm/verify/view_graph_reader.h"

namespace hisfm {
namespace {

constexpr int kNumImages = 30;

// A walk of kNumImages photos (ids 1..n in capture order): pairs up to 3
// apart match, inliers falling with the distance, and doppelgangers a
// period of 4 apart match as strongly. Image id k is named by its place in
// `order` (the k-th name of the sequence goes to order[k]).
void WriteWalkDatabase(const std::string& path,
                       const std::vector<ImageId>& order) {
  DatabaseWriter writer(path);
  writer.WriteCamera(SimplePinholeCamera(1, 1024, 768, 800));
  std::vector<std::string> names(kNumImages + 1);
  for (size_t k = 0; k < order.size(); ++k) {
    char buf[32];
    std::snprintf(buf, sizeof(buf), "%06zu.jpg", k);
    names[order[k]] = buf;
  }
  for (ImageId id = 1; id <= kNumImages; ++id) {
    writer.WriteImage({id, names[id], 1});
    Keypoints keypoints(500, 2);
    for (int r = 0; r < 500; ++r) keypoints.row(r) << 2.0f * r, 1.0f * r;
    writer.WriteKeypoints(id, keypoints);
  }
  auto write = [&](ImageId a, ImageId b, uint32_t n) {
    TwoViewGeometry g;
    g.pair = ImagePair(a, b);
    g.config = static_cast<int>(TwoViewConfig::kCalibrated);
    for (uint32_t i = 0; i < n; ++i) g.inlier_matches.push_back({i, i});
    writer.WriteTwoViewGeometry(g);
  };
  for (ImageId i = 1; i <= kNumImages; ++i) {
    for (ImageId d = 1; d <= 3 && i + d <= kNumImages; ++d) {
      write(i, i + d, 400 / d);
    }
    for (ImageId j = i + 4; j <= kNumImages; j += 4) write(i, j, 380);
  }
  writer.Close();
}

std::vector<ImageId> CaptureOrder() {
  std::vector<ImageId> order;
  for (ImageId id = 1; id <= kNumImages; ++id) order.push_back(id);
  return order;
}

// The chain's database holds exactly the consecutive pairs; a chain that
// cannot be reconstructed leaves the input as it is and cleans nothing.
TEST(SequencePass, AFailingChainRemovesNothing) {
  TempDir tmp("hisfm-sequence-pass");
  WriteWalkDatabase(tmp / "database.db", CaptureOrder());
  const std::string before = ReadTextFile(tmp / "database.db");
  int calls = 0;
  const ChainReconstructor failing = [&](const std::string& chain_db) {
    ++calls;
    const Database db(chain_db);
    const ViewGraph chain = ReadViewGraph(db, 1);
    EXPECT_EQ(chain.NumEdges(), static_cast<size_t>(kNumImages - 1));
    for (ImageId i = 1; i < kNumImages; ++i) {
      EXPECT_GT(chain.Weight(i, i + 1), 0u);
    }
    throw Error("no good initial image pair");
    return std::vector<Reconstruction>();
  };
  const SequencePassResult result = RunSequencePass(
      tmp / "database.db", 15, tmp / "work", failing, SequencePassOptions());
  EXPECT_EQ(calls, 1);
  EXPECT_TRUE(result.chain.applies);
  EXPECT_FALSE(result.ran);
  EXPECT_NE(result.note.find("could not be reconstructed"), std::string::npos)
      << result.note;
  EXPECT_TRUE(result.cleaned_database_path.empty());
  EXPECT_EQ(result.num_removed, 0u);
  EXPECT_EQ(ReadTextFile(tmp / "database.db"), before);
}

TEST(SequencePass, ShuffledNamesAreLeftAlone) {
  TempDir tmp("hisfm-sequence-pass");
  std::vector<ImageId> order = CaptureOrder();
  std::mt19937 rng(3);
  std::shuffle(order.begin(), order.end(), rng);
  WriteWalkDatabase(tmp / "database.db", order);
  int calls = 0;
  const ChainReconstructor count = [&](const std::string&) {
    ++calls;
    return std::vector<Reconstruction>();
  };
  const SequencePassResult result = RunSequencePass(
      tmp / "database.db", 15, tmp / "work", count, SequencePassOptions());
  EXPECT_EQ(calls, 0);
  EXPECT_FALSE(result.chain.applies);
  EXPECT_FALSE(result.ran);
  EXPECT_EQ(result.note, "names give no sequence");
  EXPECT_EQ(result.num_input_pairs, ReadViewGraph(Database(tmp / "database.db"), 15).NumEdges());
  EXPECT_EQ(result.ToJson()["applies"], false);
}

// A chain that registers nothing judges nothing: the cleaned copy holds
// every pair, with every inlier.
TEST(SequencePass, NoChainModelKeepsEveryPair) {
  TempDir tmp("hisfm-sequence-pass");
  WriteWalkDatabase(tmp / "database.db", CaptureOrder());
  const ChainReconstructor empty = [](const std::string&) {
    return std::vector<Reconstruction>();
  };
  const SequencePassResult result = RunSequencePass(
      tmp / "database.db", 15, tmp / "work", empty, SequencePassOptions());
  ASSERT_TRUE(result.ran) << result.note;
  EXPECT_EQ(result.num_judged, 0u);
  EXPECT_EQ(result.num_removed, 0u);
  const ViewGraph input = ReadViewGraph(Database(tmp / "database.db"), 15);
  const ViewGraph cleaned =
      ReadViewGraph(Database(result.cleaned_database_path), 15);
  EXPECT_EQ(cleaned.Edges().size(), input.Edges().size());
  EXPECT_EQ(cleaned.Weight(1, 5), input.Weight(1, 5));
}

}  // namespace
}  // namespace hisfm
