// The paper's quality proxy (HiSfM paper, Sec. IV-A, Table 1): keep a
// model's poses fixed and re-triangulate its points from the original,
// unfiltered database with `colmap point_triangulator --clear_points 1`;
// report 3D points, mean reprojection error and mean track length.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "hisfm/recon/colmap_runner.h"

namespace hisfm {

/// Statistics of the re-triangulated model.
struct RetriangulationStats {
  size_t registered_images = 0;
  size_t points3D = 0;
  double mean_reprojection_error = 0.0;
  double mean_track_length = 0.0;
  double seconds = 0.0;
};

/// Re-triangulates `model_path` (poses kept) against a private copy of
/// `database_path` (colmap opens it read-write; the input stays untouched),
/// writing into `work_path`, which is created.
RetriangulationStats Retriangulate(const std::string& database_path,
                                   const std::string& image_path,
                                   const std::string& model_path,
                                   const std::string& work_path,
                                   const ColmapRunnerOptions& colmap);

nlohmann::json ToJson(const RetriangulationStats& stats);

}  // namespace hisfm
