// End to end on real photos: eight photos of the books scene through COLMAP
// features and matching (feature_pipeline), the hierarchical mapper and the
// report, with the published reference overlaid.
#include <gtest/gtest.h>

#include <filesystem>

#include "hisfm/eval/pose_evaluation.h"
#include "hisfm/recon/feature_pipeline.h"
#include "hisfm/recon/hierarchical_mapper.h"
#include "hisfm/report/report_writer.h"
#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"
#include "hisfm/util/string_util.h"
#include "hisfm/util/test_util.h"

namespace fs = std::filesystem;

namespace hisfm {
namespace {

TEST(ReconstructionReport, BooksPhotosToReport) {
  const std::string src = SharedDataPath("yan2017/books", "images");
  const std::string ref = SharedDataPath("yan2017/books", "reference");
  if (src.empty() || ref.empty()) {
    GTEST_SKIP() << "shared data not found (HISFM_DATA_DIR)";
  }
  if (!ColmapAvailable()) GTEST_SKIP() << "colmap not installed";
  TempDir tmp;
  const std::string images = tmp / "images";
  fs::create_directories(images);
  for (int i = 0; i < 8; ++i) {
    const std::string name = StrCat("000", i, ".jpg");
    fs::copy_file(src + "/" + name, images + "/" + name);
  }
  FeaturePipelineOptions features;
  features.extractor_args = {"--SiftExtraction.max_image_size", "640"};
  const FeaturePipelineResult pipeline =
      RunFeaturePipeline(images, tmp / "ws", features);
  ASSERT_EQ(pipeline.scan.images.size(), 8u);

  MapperPaths paths;
  paths.database_path = pipeline.database_path;
  paths.image_path = images;
  paths.output_path = tmp / "ws/sparse";
  const nlohmann::json summary =
      RunHierarchicalMapper(paths, HierarchicalMapperOptions());
  EXPECT_GE(summary.value("registered_images", 0), 6);

  ReportInput input = ReadMapperReportInput(paths.output_path);
  ASSERT_TRUE(input.model.has_value());
  ASSERT_FALSE(input.hierarchy.is_null());
  input.reference = ReadModel(ref);
  input.evaluation = ToJson(EvaluateModel(*input.model, *input.reference,
                                          PoseEvaluationOptions()));
  input.stages = {{"feature extraction", pipeline.extraction_seconds, ""},
                  {"matching", pipeline.matching_seconds, ""}};
  const std::string html_path = paths.output_path + "/report.html";
  WriteReport(input, html_path);
  const std::string html = ReadTextFile(html_path);
  EXPECT_EQ(CountOccurrences(html, "<svg "), 3u);
  EXPECT_EQ(CountOccurrences(html, "http://") + CountOccurrences(html, "https://"), 0u);
  // Every photo is a dot of the view graph and a camera of the top view;
  // every reference camera is overlaid.
  EXPECT_NE(html.find("8 images in "), std::string::npos);
  EXPECT_EQ(CountOccurrences(html, "<rect x="), input.reference->NumRegImages());
  EXPECT_NE(html.find("feature extraction"), std::string::npos);
  EXPECT_NE(html.find("scaffold (colmap mapper on the skeleton)"),
            std::string::npos);
}

}  // namespace
}  // namespace hisfm
