#include "hisfm/report/report_json_check.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "hisfm/report/report_writer.h"
#include "hisfm/util/error.h"
#include "hisfm/util/test_util.h"

namespace hisfm {
namespace {

using Json = nlohmann::json;

Json ValidSummary() {
  return Json::parse(R"({
    "images": 12, "verified_pairs": 40, "verifier": "builtin",
    "registered_images": 12, "points3D": 300, "mean_track_length": 3.5,
    "mean_reprojection_error": 0.4, "work_path": "/tmp/nowhere",
    "models": [{"path": "0", "registered_images": 12, "points3D": 300}],
    "timings": {"read_database": 0.1, "scaffold": 2.0, "total": 3.0}})");
}

TEST(ReportJsonCheck, SummariesOfTheMapperPass) {
  EXPECT_EQ(FindSummaryJsonProblem(ValidSummary()), "");
  EXPECT_EQ(FindSummaryJsonProblem(Json::object()), "") << "all optional";
  Json with_nulls = ValidSummary();
  with_nulls["mean_track_length"] = nullptr;  // NaN is written as null.
  EXPECT_EQ(FindSummaryJsonProblem(with_nulls), "");
}

TEST(ReportJsonCheck, WrongTypesNameTheField) {
  Json s = ValidSummary();
  s["models"][0]["path"] = 3;
  EXPECT_EQ(FindSummaryJsonProblem(s),
            "'models[0].path' should be a string, not 3");
  s = ValidSummary();
  s["models"] = Json::object({{"path", "0"}});
  EXPECT_EQ(FindSummaryJsonProblem(s),
            "'models' should be an array, not {\"path\":\"0\"}");
  s = ValidSummary();
  s["timings"]["total"] = "long";
  EXPECT_EQ(FindSummaryJsonProblem(s),
            "'timings.total' should be a number, not \"long\"");
  s = ValidSummary();
  s["images"] = Json::array({1, 2});
  EXPECT_EQ(FindSummaryJsonProblem(s),
            "'images' should be a number, not [1,2]");
  EXPECT_EQ(FindSummaryJsonProblem(Json::array()),
            "'(the file)' should be an object, not []");
}

TEST(ReportJsonCheck, Hierarchies) {
  Json h = Json::parse(R"({"num_communities": 2,
    "images": [{"image_id": 1, "name": "a", "community": 0,
                "skeletal": true}],
    "skeleton_bridges": [{"image_id1": 1, "image_id2": 2, "inliers": 40,
                          "score": null, "role": "tree", "tree": 0}]})");
  EXPECT_EQ(FindHierarchyJsonProblem(h), "");
  h["images"][0]["skeletal"] = 1;
  EXPECT_EQ(FindHierarchyJsonProblem(h),
            "'images[0].skeletal' should be true or false, not 1");
}

TEST(ReportJsonCheck, ReportInputNamesFileAndField) {
  TempDir tmp;
  Json s = ValidSummary();
  s["models"] = "0";
  std::ofstream(tmp / "hisfm_summary.json") << s.dump();
  try {
    ReadMapperReportInput(tmp.path());
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              "mapper summary " + (tmp / "hisfm_summary.json") +
                  ": 'models' should be an array, not \"0\"");
  }
  // A broken view graph is left out; the report is still written.
  std::filesystem::create_directories(tmp / "work");
  s = ValidSummary();
  s["work_path"] = tmp / "work";
  std::ofstream(tmp / "hisfm_summary.json") << s.dump();
  std::ofstream(tmp / "work/view_graph.json") << R"({"images": 5})";
  const ReportInput input = ReadMapperReportInput(tmp.path());
  EXPECT_TRUE(input.hierarchy.is_null());
  EXPECT_NO_THROW(RenderReportHtml(input));
}

}  // namespace
}  // namespace hisfm
