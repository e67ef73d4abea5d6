#include "hisfm/recon/retriangulation.h"

#include <filesystem>

#include "hisfm/io/model.h"
#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"

namespace fs = std::filesystem;

namespace hisfm {

RetriangulationStats Retriangulate(const std::string& database_path,
                                   const std::string& image_path,
                                   const std::string& model_path,
                                   const std::string& work_path,
                                   const ColmapRunnerOptions& colmap) {
  CheckFileReadable(database_path, "database");
  std::error_code ec;
  fs::create_directories(work_path + "/model", ec);
  ThrowUnless(!ec, StrCat("cannot create ", work_path));
  const std::string db_copy = work_path + "/database.db";
  fs::copy_file(database_path, db_copy, fs::copy_options::overwrite_existing,
                ec);
  ThrowUnless(!ec, StrCat("cannot copy ", database_path, " to ", db_copy));
  RetriangulationStats stats;
  stats.seconds = RunColmap(
      colmap,
      {"point_triangulator", "--database_path", db_copy, "--image_path",
       image_path, "--input_path", model_path, "--output_path",
       work_path + "/model", "--clear_points", "1"},
      work_path + "/colmap.log");
  fs::remove(db_copy, ec);
  const Reconstruction model = ReadModel(work_path + "/model");
  stats.registered_images = model.NumRegImages();
  stats.points3D = model.NumPoints3D();
  stats.mean_reprojection_error = model.MeanReprojectionError();
  stats.mean_track_length = model.MeanTrackLength();
  return stats;
}

nlohmann::json ToJson(const RetriangulationStats& s) {
  return {{"registered_images", s.registered_images},
          {"points3D", s.points3D},
          {"mean_reprojection_error", s.mean_reprojection_error},
          {"mean_track_length", s.mean_track_length},
          {"seconds", s.seconds}};
}

}  // namespace hisfm
