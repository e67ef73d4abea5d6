#include "hisfm/report/model_export.h"

#include <cstdio>
#include <cstring>
#include <string>

#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"

namespace hisfm {

void PlyExportOptions::Check() const {
  HISFM_CHECK_OPTION(include_points, include_points || include_cameras,
                     "true when include_cameras is false");
}

namespace {

void AppendVertex(const Eigen::Vector3d& xyz, const uint8_t rgb[3],
                  bool binary, std::string* out) {
  if (binary) {
    for (int i = 0; i < 3; ++i) {
      const float v = static_cast<float>(xyz(i));
      char bytes[4];
      std::memcpy(bytes, &v, 4);  // x86 and ARM Linux are little-endian.
      out->append(bytes, 4);
    }
    out->append(reinterpret_cast<const char*>(rgb), 3);
    return;
  }
  char line[160];
  std::snprintf(line, sizeof(line), "%.9g %.9g %.9g %u %u %u\n", xyz(0),
                xyz(1), xyz(2), unsigned{rgb[0]}, unsigned{rgb[1]},
                unsigned{rgb[2]});
  *out += line;
}

}  // namespace

PlyExportSummary WriteModelPly(const Reconstruction& model,
                               const std::string& path,
                               const PlyExportOptions& options) {
  options.Check();
  PlyExportSummary summary;
  if (options.include_points) summary.num_points = model.NumPoints3D();
  if (options.include_cameras) summary.num_cameras = model.NumRegImages();
  std::string out =
      StrCat("ply\nformat ",
             options.binary ? "binary_little_endian" : "ascii",
             " 1.0\ncomment written by HiSfM: ", summary.num_points,
             " points, then ", summary.num_cameras,
             " camera centres\nelement vertex ",
             summary.num_points + summary.num_cameras,
             "\nproperty float x\nproperty float y\nproperty float z\n"
             "property uchar red\nproperty uchar green\nproperty uchar "
             "blue\nend_header\n");
  out.reserve(out.size() + (summary.num_points + summary.num_cameras) * 15);
  if (options.include_points) {
    for (const auto& [id, point] : model.points3D) {
      const uint8_t rgb[3] = {point.color(0), point.color(1), point.color(2)};
      AppendVertex(point.xyz, rgb, options.binary, &out);
    }
  }
  if (options.include_cameras) {
    const uint8_t* rgb = options.camera_color.data();
    for (const auto& [id, image] : model.images) {
      AppendVertex(image.ProjectionCenter(), rgb, options.binary, &out);
    }
  }
  WriteFileAtomically(path, out);
  return summary;
}

ModelStatistics ComputeModelStatistics(const Reconstruction& model) {
  ModelStatistics s;
  s.num_cameras = model.cameras.size();
  s.num_images = model.NumRegImages();
  s.num_points3D = model.NumPoints3D();
  s.num_observations = model.NumObservations();
  s.mean_track_length = model.MeanTrackLength();
  s.mean_observations_per_image =
      s.num_images == 0 ? 0.0
                        : static_cast<double>(s.num_observations) /
                              static_cast<double>(s.num_images);
  s.mean_reprojection_error = model.MeanReprojectionError();
  return s;
}

nlohmann::json ToJson(const ModelStatistics& s) {
  return {{"num_cameras", s.num_cameras},
          {"num_images", s.num_images},
          {"num_points3D", s.num_points3D},
          {"num_observations", s.num_observations},
          {"mean_track_length", s.mean_track_length},
          {"mean_observations_per_image", s.mean_observations_per_image},
          {"mean_reprojection_error", s.mean_reprojection_error}};
}

std::string FormatModelStatistics(const ModelStatistics& s) {
  char buf[512];
  std::snprintf(buf, sizeof(buf),
                "cameras: %zu\nimages: %zu\npoints: %zu\nobservations: %zu\n"
                "mean track length: %.6f\nmean observations per image: %.6f\n"
                "mean reprojection error: %.6f px\n",
                s.num_cameras, s.num_images, s.num_points3D,
                s.num_observations, s.mean_track_length,
                s.mean_observations_per_image, s.mean_reprojection_error);
  return buf;
}

}  // namespace hisfm
