// A model for viewers and people: PLY export of the points (with their
// colours) and the camera centres (as vertices of a chosen colour), and the
// statistics `colmap model_analyzer` prints.
//
// PLY: the format of Turk (1994) as read by MeshLab, CloudCompare and
// Open3D: a header listing one element "vertex" with float x, y, z and
// uchar red, green, blue, followed by the vertices in binary little-endian
// or ASCII.
#pragma once

#include <array>
#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>

#include "hisfm/io/model.h"

namespace hisfm {

struct PlyExportOptions {
  /// binary_little_endian (smaller, faster) if true, else ascii.
  bool binary = true;
  /// Write the 3D points with their colours.
  bool include_points = true;
  /// Write the camera centres as vertices of camera_color.
  bool include_cameras = true;
  /// Colour of the camera vertices (default: pure red, rare in photos).
  std::array<uint8_t, 3> camera_color = {255, 0, 0};

  /// Throws hisfm::Error if nothing would be written.
  void Check() const;
};

/// What WriteModelPly wrote.
struct PlyExportSummary {
  size_t num_points = 0;
  size_t num_cameras = 0;
};

/// Writes the model as a PLY point cloud to `path` (through a temporary
/// file and a rename): points first (in point id order), then camera centres
/// (in image id order). Throws hisfm::Error if it cannot be written.
PlyExportSummary WriteModelPly(const Reconstruction& model,
                               const std::string& path,
                               const PlyExportOptions& options);

/// The numbers `colmap model_analyzer` prints for a model.
struct ModelStatistics {
  size_t num_cameras = 0;
  /// Registered images (a COLMAP model lists only registered images).
  size_t num_images = 0;
  size_t num_points3D = 0;
  size_t num_observations = 0;
  /// Observations per point (0 without points).
  double mean_track_length = 0.0;
  /// Observations per registered image (0 without images).
  double mean_observations_per_image = 0.0;
  /// Mean of the points' stored reprojection errors in pixels (COLMAP's
  /// definition; 0 without points).
  double mean_reprojection_error = 0.0;
};

ModelStatistics ComputeModelStatistics(const Reconstruction& model);

/// {"num_cameras": ..., "num_images": ..., "num_points3D": ...,
///  "num_observations": ..., "mean_track_length": ...,
///  "mean_observations_per_image": ..., "mean_reprojection_error": ...}
nlohmann::json ToJson(const ModelStatistics& stats);

/// One "label: value" line per number, like colmap model_analyzer.
std::string FormatModelStatistics(const ModelStatistics& stats);

}  // namespace hisfm
