// The HTML report of a run: one self-contained file (inline CSS and SVG,
// no script, no external reference) that a person can open in any browser.
//
// Sections:
//   - summary figures (images, registered, points, track length, errors,
//     hierarchy counts, total time) and, when given, the evaluation against
//     a reference and a comparison of methods;
//   - the view graph: images coloured by community, skeleton bridges,
//     rejected bridges with their verifier scores, intra-community skeleton
//     edges and leaf edges; images are laid out by their reconstructed
//     camera centres (top view, hisfm/report/top_view.h) when a model
//     exists, else on a circle per community; layers can be switched off;
//   - a top view of the cameras and (subsampled) points, with the reference
//     cameras overlaid after a robust similarity alignment;
//   - the time of each stage; the bridges as a table; skipped input files.
#pragma once

#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "hisfm/io/model.h"

namespace hisfm {

/// One timed stage (e.g. "feature extraction").
struct ReportStage {
  std::string name;
  double seconds = 0.0;
  /// Shown beside the time, e.g. "skipped: unchanged (recorded time)".
  std::string note;
};

/// One method of a side-by-side comparison (e.g. COLMAP vs HiSfM).
struct ReportMethodResult {
  std::string method;
  /// Registered images (over all models) and images in the input.
  size_t registered_images = 0;
  size_t num_images = 0;
  /// Number of models written.
  size_t num_models = 0;
  double seconds = 0.0;
  /// EvaluateModel(s) ToJson against the ground truth or reference (null if
  /// not evaluated).
  nlohmann::json evaluation;
};

/// A further model drawn as its own top view (e.g. vanilla COLMAP's result
/// beside HiSfM's), with the report's reference overlaid.
struct ReportModelView {
  std::string title;
  Reconstruction model;
};

/// Everything the report shows; every part is optional.
struct ReportInput {
  /// Page title.
  std::string title = "HiSfM reconstruction report";
  /// hisfm_summary.json of RunHierarchicalMapper (null if none).
  nlohmann::json summary;
  /// HierarchyToJson, as in view_graph.json (null if none).
  nlohmann::json hierarchy;
  /// The (largest) reconstructed model.
  std::optional<Reconstruction> model;
  /// A reference model with the same image names (ground truth).
  std::optional<Reconstruction> reference;
  /// The model's evaluation against the reference: ToJson(PoseEvaluation)
  /// or ToJson(MultiModelEvaluation) (null if none).
  nlohmann::json evaluation;
  /// Stages timed outside the mapper (feature extraction, matching); the
  /// summary's "timings" follow them in the stage chart.
  std::vector<ReportStage> stages;
  /// Further models drawn after the main one.
  std::vector<ReportModelView> extra_views;
  /// Methods compared side by side (may be empty).
  std::vector<ReportMethodResult> comparison;
  /// Input files that were skipped and why.
  std::vector<std::pair<std::string, std::string>> skipped_files;
  /// Extra facts shown in the header table (label, value), e.g. paths.
  std::vector<std::pair<std::string, std::string>> facts;
};

struct ReportOptions {
  /// At most this many 3D points are drawn (evenly subsampled).
  size_t max_points = 20000;
  /// At most this many rejected bridges get a score label in the drawing.
  size_t max_bridge_labels = 40;
  /// At most this many rows in the bridge table.
  size_t max_table_rows = 200;
  /// Width of the drawings in SVG units (they scale to the page).
  int drawing_width = 1000;

  void Check() const;
};

/// The report as one HTML document.
std::string RenderReportHtml(const ReportInput& input,
                             const ReportOptions& options = ReportOptions());

/// Writes RenderReportHtml to `html_path` (through a temporary file and a
/// rename). Throws hisfm::Error if it cannot be written.
void WriteReport(const ReportInput& input, const std::string& html_path,
                 const ReportOptions& options = ReportOptions());

/// Collects the report input of a finished `hisfm mapper` run from its
/// output folder: OUTPUT/hisfm_summary.json, the model OUTPUT/0 (the
/// largest), and the hierarchy from the summary's work_path
/// (view_graph.json) if it is still there. Throws hisfm::Error if the
/// summary is missing.
ReportInput ReadMapperReportInput(const std::string& output_path);

}  // namespace hisfm
