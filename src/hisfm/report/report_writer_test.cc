#include "hisfm/report/report_writer.h"

#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <set>

#include "hisfm/io/model.h"
#include "hisfm/report/report_test_util.h"
#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"
#include "hisfm/util/string_util.h"
#include "hisfm/util/test_util.h"

namespace fs = std::filesystem;

namespace hisfm {
namespace {

// The part of the page between `begin` and the next `end`.
std::string Between(const std::string& text, const std::string& begin,
                    const std::string& end) {
  const size_t a = text.find(begin);
  if (a == std::string::npos) return "";
  const size_t b = text.find(end, a);
  return text.substr(a, b == std::string::npos ? std::string::npos : b - a);
}

// A hierarchy over the ring model's images: communities of four
// consecutive images, chains inside, bridges between neighbours, one
// rejected bridge across the ring and a leaf edge per community.
nlohmann::json RingHierarchy(const Reconstruction& model) {
  nlohmann::json images = nlohmann::json::array();
  nlohmann::json intra = nlohmann::json::array();
  nlohmann::json leaves = nlohmann::json::array();
  nlohmann::json bridges = nlohmann::json::array();
  const int n = static_cast<int>(model.images.size());
  for (const auto& [id, image] : model.images) {
    const int c = static_cast<int>(id - 1) / 4;
    const bool skeletal = (id - 1) % 4 != 3;
    images.push_back({{"image_id", id},
                      {"name", image.name},
                      {"community", c},
                      {"skeletal", skeletal}});
    if ((id - 1) % 4 == 1 || (id - 1) % 4 == 2) {
      intra.push_back({{"image_id1", id - 1}, {"image_id2", id},
                       {"inliers", 200}});
    }
    if (!skeletal) {
      leaves.push_back({{"image_id1", id - 1}, {"image_id2", id},
                        {"inliers", 150}});
    }
    if ((id - 1) % 4 == 2 && static_cast<int>(id) + 2 <= n) {
      bridges.push_back({{"image_id1", id}, {"image_id2", id + 2},
                         {"community1", c}, {"community2", c + 1},
                         {"inliers", 90}, {"score", 0.93},
                         {"role", "tree"}, {"tree", 0}});
    }
  }
  const nlohmann::json rejected = nlohmann::json::array(
      {{{"image_id1", 1}, {"image_id2", n / 2 + 1}, {"community1", 0},
        {"community2", n / 8}, {"inliers", 120}, {"score", 0.123},
        {"role", "tree"}, {"tree", -1}}});
  return {{"num_images", n},
          {"num_communities", (n + 3) / 4},
          {"images", images},
          {"skeleton_bridges", bridges},
          {"rejected_bridges", rejected},
          {"skeleton_intra_edges", intra},
          {"leaf_edges", leaves},
          {"components", nlohmann::json::array()},
          {"isolated_images", nlohmann::json::array()}};
}

ReportInput FullInput() {
  ReportInput in;
  in.title = "Ring <test> & report";
  in.model = testing_scene::RingModel(16, 3000, 5.0);
  in.hierarchy = RingHierarchy(*in.model);
  Reconstruction reference = testing_scene::RingModel(16, 0, 1.0);
  in.reference = reference;
  in.summary = {{"images", 16},
                {"registered_images", 16},
                {"verified_pairs", 80},
                {"communities", 4},
                {"num_trees", 1},
                {"skeleton_images", 12},
                {"skeleton_bridges", 3},
                {"rejected_bridges", 1},
                {"verifier", "builtin"},
                {"verifier_calls", 4},
                {"verified_fraction", 0.05},
                {"models", nlohmann::json::array({{{"path", "0"}}})},
                {"image_path", "/data/ring/images"},
                {"timings",
                 {{"read_database", 0.1},
                  {"build_hierarchy", 0.2},
                  {"scaffold", 7.5},
                  {"attach", 2.0},
                  {"total", 9.9}}}};
  in.evaluation = {{"correct", false},
                   {"verdict", "incorrect"},
                   {"verdict_reason", "50% of pairs within 5 deg"},
                   {"num_registered", 16},
                   {"num_reference_images", 16},
                   {"num_pairs", 120},
                   {"median_rotation_error_deg", 12.5},
                   {"median_translation_error_deg", 3.25},
                   {"pairs_within",
                    {{{"threshold_deg", 5.0}, {"fraction", 0.5}}}}};
  in.stages = {{"feature extraction", 27.5, ""},
               {"feature matching", 97.0, "skipped: unchanged"}};
  ReportMethodResult colmap;
  colmap.method = "COLMAP mapper";
  colmap.registered_images = 16;
  colmap.num_images = 16;
  colmap.num_models = 1;
  colmap.seconds = 30;
  colmap.evaluation = in.evaluation;
  ReportMethodResult hisfm = colmap;
  hisfm.method = "HiSfM mapper";
  hisfm.seconds = 12;
  hisfm.evaluation = {{"correct", true}, {"verdict", "correct"}};
  in.comparison = {colmap, hisfm};
  in.skipped_files = {{"bad<1>.jpg", "not a JPEG, PNG, TIFF or BMP file"}};
  in.facts = {{"workspace", "/tmp/ws & co"}};
  return in;
}

TEST(RenderReportHtml, IsSelfContainedWithAllDrawings) {
  const ReportInput in = FullInput();
  const std::string html = RenderReportHtml(in);
  EXPECT_EQ(html.rfind("<!DOCTYPE html>", 0), 0u);
  EXPECT_EQ(CountOccurrences(html, "http://"), 0u);
  EXPECT_EQ(CountOccurrences(html, "https://"), 0u);
  EXPECT_EQ(CountOccurrences(html, "<script"), 0u);
  EXPECT_EQ(CountOccurrences(html, "src="), 0u);
  EXPECT_EQ(CountOccurrences(html, "href="), 0u);
  EXPECT_EQ(CountOccurrences(html, "@import"), 0u);
  EXPECT_EQ(CountOccurrences(html, "url("), 0u);
  // View graph, top view and stage chart.
  EXPECT_EQ(CountOccurrences(html, "<svg "), 3u);
  EXPECT_EQ(CountOccurrences(html, "</svg>"), 3u);
  EXPECT_EQ(CountOccurrences(html, "<g ") + CountOccurrences(html, "<g>"), CountOccurrences(html, "</g>"));
  EXPECT_EQ(CountOccurrences(html, "<text"), CountOccurrences(html, "</text>"));
  EXPECT_EQ(CountOccurrences(html, "<table"), CountOccurrences(html, "</table>"));
  EXPECT_EQ(CountOccurrences(html, "<title>"), CountOccurrences(html, "</title>"));
}

TEST(RenderReportHtml, DrawsTheHierarchy) {
  const ReportInput in = FullInput();
  const std::string html = RenderReportHtml(in);
  const std::string graph =
      Between(html, "aria-label=\"view graph\"", "</svg>");
  ASSERT_FALSE(graph.empty());
  // One dot per image, skeletal ones outlined.
  EXPECT_EQ(CountOccurrences(Between(graph, "class=\"nodes\"", "</g>\n<g"), "<circle"),
            16u);
  EXPECT_EQ(CountOccurrences(graph, "class=\"skel\""), 12u);
  EXPECT_EQ(CountOccurrences(graph, "class=\"leaf\""), 4u);
  // Edge layers with one line per edge.
  EXPECT_EQ(CountOccurrences(Between(graph, "class=\"e-bridge\"", "</g>\n<g"), "<line"),
            3u);
  EXPECT_EQ(CountOccurrences(Between(graph, "class=\"e-rejected\"", "</g>\n<g"), "<line"),
            1u);
  EXPECT_EQ(CountOccurrences(Between(graph, "class=\"e-leaf\"", "</g>\n<g"), "<line"),
            4u);
  EXPECT_EQ(CountOccurrences(Between(graph, "class=\"e-intra\"", "</g>\n<g class"),
                  "<line"),
            8u);
  // The rejected bridge's score is written beside it, and a colour per
  // community is used.
  EXPECT_NE(Between(graph, "class=\"e-label\"", "</g>").find(">0.12<"),
            std::string::npos);
  std::set<std::string> fills;
  for (size_t pos = graph.find("fill=\"hsl("); pos != std::string::npos;
       pos = graph.find("fill=\"hsl(", pos + 1)) {
    fills.insert(graph.substr(pos, graph.find('"', pos + 6) - pos));
  }
  EXPECT_EQ(fills.size(), 4u);
  EXPECT_NE(html.find("Images are placed at their reconstructed camera"),
            std::string::npos);
  // Layer switches.
  for (const char* id : {"t-leaf", "t-intra", "t-bridge", "t-rejected"}) {
    EXPECT_NE(html.find(StrCat("id=\"", id, "\"")), std::string::npos) << id;
  }
}

TEST(RenderReportHtml, TopViewWithReferenceAndSubsampledPoints) {
  ReportInput in = FullInput();
  ReportOptions options;
  options.max_points = 500;
  const std::string html = RenderReportHtml(in, options);
  const std::string top = Between(html, "aria-label=\"top view\"", "</svg>");
  ASSERT_FALSE(top.empty());
  const size_t drawn = CountOccurrences(top, "h0");
  EXPECT_GT(drawn, 400u);
  EXPECT_LE(drawn, 500u);
  EXPECT_EQ(CountOccurrences(Between(top, "class=\"cams\"", "</svg>"), "<circle"), 16u);
  // Reference squares after the alignment (scale 1 -> 5), one per camera.
  EXPECT_EQ(CountOccurrences(Between(top, "class=\"ref\"", "</g>"), "<rect"), 16u);
  EXPECT_NE(html.find("robust similarity alignment on 16 common images"),
            std::string::npos);
  // No reference: no squares.
  in.reference.reset();
  const std::string plain = RenderReportHtml(in, options);
  EXPECT_EQ(CountOccurrences(plain, "class=\"ref\""), 0u);
}

TEST(RenderReportHtml, SummaryEvaluationComparisonStagesAndEscaping) {
  const std::string html = RenderReportHtml(FullInput());
  EXPECT_NE(html.find("Ring &lt;test&gt; &amp; report"), std::string::npos);
  EXPECT_EQ(html.find("Ring <test>"), std::string::npos);
  EXPECT_NE(html.find("bad&lt;1&gt;.jpg"), std::string::npos);
  EXPECT_NE(html.find("/tmp/ws &amp; co"), std::string::npos);
  EXPECT_NE(html.find("16 / 16"), std::string::npos);
  EXPECT_NE(html.find("3000"), std::string::npos);  // points
  EXPECT_NE(html.find("50% of pairs within 5 deg"), std::string::npos);
  EXPECT_NE(html.find("12.50&deg;"), std::string::npos);
  EXPECT_NE(html.find("COLMAP mapper"), std::string::npos);
  EXPECT_NE(html.find("HiSfM mapper"), std::string::npos);
  EXPECT_EQ(CountOccurrences(html, "class=\"badge ok\""), 1u);
  const std::string stages = Between(html, "aria-label=\"stage times\"",
                                     "</svg>");
  EXPECT_EQ(CountOccurrences(stages, "class=\"bar\""), 6u);
  for (const char* name :
       {"feature extraction", "feature matching", "read database",
        "scaffold (colmap mapper on the skeleton)", "attach leaves"}) {
    EXPECT_NE(stages.find(name), std::string::npos) << name;
  }
  EXPECT_NE(stages.find("skipped: unchanged"), std::string::npos);
  EXPECT_NE(stages.find("97.0 s"), std::string::npos);
}

TEST(RenderReportHtml, CircleLayoutWithoutAModelAndUnregisteredImages) {
  ReportInput in = FullInput();
  Reconstruction model = *in.model;
  in.model.reset();
  in.reference.reset();
  std::string html = RenderReportHtml(in);
  EXPECT_NE(html.find("Each community is drawn on its own circle"),
            std::string::npos);
  EXPECT_EQ(CountOccurrences(html, "<svg "), 2u);  // No top view.
  EXPECT_EQ(CountOccurrences(html, "aria-label=\"top view\""), 0u);

  // Three images missing from the model: drawn hollow, in a separate row.
  for (ImageId id : {2u, 7u, 16u}) model.images.erase(id);
  in.model = model;
  html = RenderReportHtml(in);
  const std::string graph =
      Between(html, "aria-label=\"view graph\"", "</svg>");
  EXPECT_EQ(CountOccurrences(graph, " unreg\""), 3u);
  EXPECT_NE(graph.find("not registered:"), std::string::npos);
  EXPECT_EQ(CountOccurrences(Between(graph, "class=\"nodes\"", "</g>\n<g"), "<circle"),
            16u);
}

TEST(RenderReportHtml, ExtraViewsAndNonOverlappingScoreLabels) {
  ReportInput in = FullInput();
  in.extra_views.push_back(
      {"COLMAP <folded>", testing_scene::RingModel(16, 100, 2.0)});
  // Many rejected bridges through the middle of the ring.
  for (uint32_t i = 2; i <= 8; ++i) {
    in.hierarchy["rejected_bridges"].push_back(
        {{"image_id1", i}, {"image_id2", i + 8}, {"inliers", 50 + i},
         {"score", 0.01 * i}});
  }
  const std::string html = RenderReportHtml(in);
  EXPECT_EQ(CountOccurrences(html, "aria-label=\"top view\""), 2u);
  EXPECT_NE(html.find("<h2>COLMAP &lt;folded&gt;</h2>"), std::string::npos);
  const std::string labels = Between(html, "class=\"e-label\"", "</g>");
  std::vector<Eigen::Vector2d> at;
  for (size_t pos = labels.find("<text x=\""); pos != std::string::npos;
       pos = labels.find("<text x=\"", pos + 1)) {
    double x = 0, y = 0;
    ASSERT_EQ(std::sscanf(labels.c_str() + pos, "<text x=\"%lf\" y=\"%lf\"",
                          &x, &y),
              2);
    at.emplace_back(x, y);
  }
  ASSERT_EQ(at.size(), 8u);
  for (size_t i = 0; i < at.size(); ++i) {
    for (size_t j = i + 1; j < at.size(); ++j) {
      EXPECT_FALSE(std::abs(at[i].x() - at[j].x()) < 20 &&
                   std::abs(at[i].y() - at[j].y()) < 8)
          << i << " and " << j << " overlap";
    }
  }
}

TEST(RenderReportHtml, EmptyInputGivesAValidPage) {
  const std::string html = RenderReportHtml(ReportInput());
  EXPECT_EQ(html.rfind("<!DOCTYPE html>", 0), 0u);
  EXPECT_NE(html.find("</html>"), std::string::npos);
  EXPECT_EQ(CountOccurrences(html, "<svg"), 0u);
}

TEST(ReadMapperReportInput, ReadsSummaryModelAndHierarchy) {
  TempDir tmp;
  const Reconstruction model = testing_scene::RingModel(8, 30, 2.0);
  fs::create_directories(tmp / "out/0");
  fs::create_directories(tmp / "out_work");
  WriteModelBinary(model, tmp / "out/0");
  const nlohmann::json summary = {
      {"registered_images", 8},
      {"work_path", tmp / "out_work"},
      {"models", nlohmann::json::array({{{"path", "0"}}})}};
  WriteFileAtomically(tmp / "out/hisfm_summary.json", summary.dump());
  WriteFileAtomically(tmp / "out_work/view_graph.json",
                      RingHierarchy(model).dump());
  const ReportInput in = ReadMapperReportInput(tmp / "out");
  ASSERT_TRUE(in.model.has_value());
  EXPECT_EQ(in.model->NumRegImages(), 8u);
  EXPECT_EQ(in.hierarchy["images"].size(), 8u);
  EXPECT_EQ(in.summary["registered_images"], 8);
  WriteReport(in, tmp / "out/report.html");
  EXPECT_NE(ReadTextFile(tmp / "out/report.html").find("view graph"),
            std::string::npos);
  EXPECT_THROW(ReadMapperReportInput(tmp / "missing"), Error);
}

}  // namespace
}  // namespace hisfm
