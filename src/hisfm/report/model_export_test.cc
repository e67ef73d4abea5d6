#include "hisfm/report/model_export.h"

#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <sstream>

#include "hisfm/report/report_test_util.h"
#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"
#include "hisfm/util/test_util.h"

namespace hisfm {
namespace {

// Splits a PLY file into its header lines and the body bytes.
void SplitPly(const std::string& text, std::vector<std::string>* header,
              std::string* body) {
  const size_t end = text.find("end_header\n");
  ASSERT_NE(end, std::string::npos);
  std::istringstream in(text.substr(0, end));
  std::string line;
  while (std::getline(in, line)) header->push_back(line);
  *body = text.substr(end + std::strlen("end_header\n"));
}

TEST(WriteModelPly, AsciiHoldsPointsThenCameraCentres) {
  const Reconstruction model = testing_scene::RingModel(5, 20, 4.0);
  TempDir tmp;
  PlyExportOptions options;
  options.binary = false;
  options.camera_color = {1, 2, 3};
  const PlyExportSummary summary =
      WriteModelPly(model, tmp / "m.ply", options);
  EXPECT_EQ(summary.num_points, 20u);
  EXPECT_EQ(summary.num_cameras, 5u);
  std::vector<std::string> header;
  std::string body;
  SplitPly(ReadTextFile(tmp / "m.ply"), &header, &body);
  ASSERT_GE(header.size(), 3u);
  EXPECT_EQ(header[0], "ply");
  EXPECT_EQ(header[1], "format ascii 1.0");
  EXPECT_NE(std::find(header.begin(), header.end(), "element vertex 25"),
            header.end());
  std::istringstream in(body);
  std::vector<std::array<double, 6>> rows;
  std::array<double, 6> row;
  while (in >> row[0] >> row[1] >> row[2] >> row[3] >> row[4] >> row[5]) {
    rows.push_back(row);
  }
  ASSERT_EQ(rows.size(), 25u);
  size_t k = 0;
  for (const auto& [id, p] : model.points3D) {
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(rows[k][i], p.xyz(i), 1e-5);
    for (int i = 0; i < 3; ++i) EXPECT_EQ(rows[k][3 + i], p.color(i));
    ++k;
  }
  for (const auto& [id, image] : model.images) {
    const Eigen::Vector3d c = image.ProjectionCenter();
    for (int i = 0; i < 3; ++i) EXPECT_NEAR(rows[k][i], c(i), 1e-5);
    EXPECT_EQ(rows[k][3], 1);
    EXPECT_EQ(rows[k][4], 2);
    EXPECT_EQ(rows[k][5], 3);
    ++k;
  }
}

TEST(WriteModelPly, BinaryIsLittleEndianFloatsAndBytes) {
  const Reconstruction model = testing_scene::RingModel(4, 10, 2.0);
  TempDir tmp;
  PlyExportOptions options;
  options.include_points = false;
  WriteModelPly(model, tmp / "c.ply", options);
  std::vector<std::string> header;
  std::string body;
  SplitPly(ReadTextFile(tmp / "c.ply"), &header, &body);
  EXPECT_EQ(header[1], "format binary_little_endian 1.0");
  ASSERT_EQ(body.size(), 4u * 15u);
  const Eigen::Vector3d c = model.images.at(3).ProjectionCenter();
  float xyz[3];
  std::memcpy(xyz, body.data() + 2 * 15, 12);
  for (int i = 0; i < 3; ++i) EXPECT_NEAR(xyz[i], c(i), 1e-5);
  EXPECT_EQ(static_cast<uint8_t>(body[2 * 15 + 12]), 255);
  EXPECT_EQ(static_cast<uint8_t>(body[2 * 15 + 13]), 0);
  options.include_cameras = false;
  EXPECT_THROW(WriteModelPly(model, tmp / "x.ply", options), Error);
}

TEST(ModelStatistics, CountsOfAKnownModel) {
  const Reconstruction model = testing_scene::RingModel(4, 10, 2.0);
  const ModelStatistics s = ComputeModelStatistics(model);
  EXPECT_EQ(s.num_cameras, 1u);
  EXPECT_EQ(s.num_images, 4u);
  EXPECT_EQ(s.num_points3D, 10u);
  EXPECT_EQ(s.num_observations, 20u);
  EXPECT_DOUBLE_EQ(s.mean_track_length, 2.0);
  EXPECT_DOUBLE_EQ(s.mean_observations_per_image, 5.0);
  double sum = 0;
  for (const auto& [id, p] : model.points3D) sum += p.error;
  EXPECT_NEAR(s.mean_reprojection_error, sum / 10, 1e-12);
  EXPECT_EQ(ToJson(s)["num_observations"], 20);
  EXPECT_NE(FormatModelStatistics(s).find("mean track length: 2.000000"),
            std::string::npos);
  const ModelStatistics empty = ComputeModelStatistics(Reconstruction());
  EXPECT_EQ(empty.mean_observations_per_image, 0.0);
}

// The numbers agree with `colmap model_analyzer` on the cup reference.
TEST(ModelStatistics, AgreesWithColmapModelAnalyzer) {
  const std::string ref = SharedDataPath("yan2017/cup", "reference");
  if (ref.empty()) GTEST_SKIP() << "shared data not found (HISFM_DATA_DIR)";
  if (!ColmapAvailable()) GTEST_SKIP() << "colmap not installed";
  TempDir tmp;
  ASSERT_EQ(RunShell("colmap model_analyzer --path '" + ref + "'",
                     tmp / "log.txt"),
            0);
  const std::string log = ReadTextFile(tmp / "log.txt");
  auto value = [&](const std::string& label) {
    const size_t pos = log.find(label + ": ");
    EXPECT_NE(pos, std::string::npos) << label;
    return pos == std::string::npos
               ? -1.0
               : std::stod(log.substr(pos + label.size() + 2));
  };
  const ModelStatistics s = ComputeModelStatistics(ReadModel(ref));
  EXPECT_EQ(s.num_cameras, value("Cameras"));
  EXPECT_EQ(s.num_images, value("Registered images"));
  EXPECT_EQ(s.num_points3D, value("Points"));
  EXPECT_EQ(s.num_observations, value("Observations"));
  EXPECT_NEAR(s.mean_track_length, value("Mean track length"), 1e-5);
  EXPECT_NEAR(s.mean_observations_per_image,
              value("Mean observations per image"), 1e-5);
  EXPECT_NEAR(s.mean_reprojection_error, value("Mean reprojection error"),
              1e-5);
}

}  // namespace
}  // namespace hisfm
