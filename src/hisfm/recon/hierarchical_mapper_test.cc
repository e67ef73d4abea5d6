#include "hisfm/recon/hierarchical_mapper.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "hisfm/io/database.h"
#include "hisfm/io/database_writer.h"
#include "hisfm/io/model.h"
#include "hisfm/util/error.h"
#include "hisfm/util/test_util.h"

namespace fs = std::filesystem;

namespace hisfm {
namespace {

std::string ErrorOf(const MapperPaths& paths,
                    const HierarchicalMapperOptions& options) {
  try {
    RunHierarchicalMapper(paths, options);
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

MapperPaths CupPaths(const TempDir& tmp) {
  MapperPaths p;
  p.database_path = SharedDataPath("yan2017/cup", "database.db");
  p.image_path = SharedDataPath("yan2017/cup", "images");
  p.output_path = tmp / "out";
  return p;
}

TEST(HierarchicalMapper, BadInputGivesOneLineErrorsAndWritesNothing) {
  TempDir tmp;
  HierarchicalMapperOptions options;
  options.verifier.verifier = "none";
  MapperPaths paths;
  paths.database_path = tmp / "missing.db";
  paths.image_path = tmp.path();
  paths.output_path = tmp / "out";
  EXPECT_NE(ErrorOf(paths, options).find("does not exist"), std::string::npos);

  // A database without verified pairs.
  {
    DatabaseWriter w(tmp / "empty.db");
    DatabaseCamera cam;
    cam.camera_id = 1;
    cam.model_id = 0;
    cam.width = 100;
    cam.height = 100;
    cam.params = {100, 50, 50};
    w.WriteCamera(cam);
    w.WriteImage({1, "a.jpg", 1});
    w.WriteImage({2, "b.jpg", 1});
  }
  paths.database_path = tmp / "empty.db";
  const std::string no_pairs = ErrorOf(paths, options);
  EXPECT_NE(no_pairs.find("no verified image pairs"), std::string::npos)
      << no_pairs;
  EXPECT_EQ(no_pairs.find('\n'), std::string::npos);
  EXPECT_FALSE(fs::exists(tmp / "out") && !fs::is_empty(tmp / "out"));

  paths.image_path = tmp / "no_such_folder";
  EXPECT_NE(ErrorOf(paths, options).find("image folder"), std::string::npos);

  // A non-empty output folder is refused and left as it was.
  paths.image_path = tmp.path();
  fs::create_directories(tmp / "full");
  std::ofstream(tmp / "full/keep.txt") << "x";
  paths.output_path = tmp / "full";
  EXPECT_NE(ErrorOf(paths, options).find("not empty"), std::string::npos);
  EXPECT_TRUE(fs::exists(tmp / "full/keep.txt"));

  // colmap missing.
  paths.output_path = tmp / "out2";
  options.colmap.colmap_path = "/nonexistent/colmap";
  paths.database_path = tmp / "empty.db";
  EXPECT_NE(ErrorOf(paths, options).find("colmap not found"),
            std::string::npos);
  EXPECT_FALSE(fs::exists(tmp / "out2"));
}

TEST(HierarchicalMapper, FailingColmapReportsCommandAndLog) {
  const std::string db = SharedDataPath("yan2017/cup", "database.db");
  if (db.empty()) GTEST_SKIP() << "shared data not found: " << SharedDataDir();
  if (!ColmapAvailable()) GTEST_SKIP() << "colmap is not installed";
  TempDir tmp;
  MapperPaths paths = CupPaths(tmp);
  HierarchicalMapperOptions options;
  options.verifier.verifier = "none";
  options.mapper_args = {"--Mapper.no_such_option", "1"};
  const std::string error = ErrorOf(paths, options);
  EXPECT_NE(error.find("colmap failed"), std::string::npos) << error;
  EXPECT_NE(error.find("mapper --database_path"), std::string::npos) << error;
  EXPECT_FALSE(fs::exists(paths.output_path));
}

TEST(HierarchicalMapper, RegistersAllCupImages) {
  const std::string db = SharedDataPath("yan2017/cup", "database.db");
  if (db.empty()) GTEST_SKIP() << "shared data not found: " << SharedDataDir();
  if (!ColmapAvailable()) GTEST_SKIP() << "colmap is not installed";
  TempDir tmp;
  const uint64_t before = FileFingerprint(db);
  MapperPaths paths = CupPaths(tmp);
  paths.options_record = "HiSfM.top_k=1\n";
  HierarchicalMapperOptions options;
  options.verifier.verifier = "none";
  const nlohmann::json summary = RunHierarchicalMapper(paths, options);
  EXPECT_EQ(FileFingerprint(db), before) << "the input database changed";
  EXPECT_EQ(summary["images"], 64);
  EXPECT_EQ(summary["verified_pairs"], 2016);
  EXPECT_EQ(summary["registered_images"], 64);
  EXPECT_LT(summary["skeleton_images"].get<int>(), 64);
  EXPECT_LT(summary["hierarchy_edges"].get<int>(), 2016 / 10);
  EXPECT_GT(summary["points3D"].get<int>(), 1000);
  EXPECT_LT(summary["mean_reprojection_error"].get<double>(), 2.0);
  const Reconstruction model = ReadModel(paths.output_path + "/0");
  EXPECT_EQ(model.NumRegImages(), 64u);
  EXPECT_TRUE(fs::exists(paths.output_path + "/hisfm_summary.json"));
  EXPECT_TRUE(fs::exists(paths.output_path + "/hisfm_options.ini"));
  EXPECT_TRUE(fs::exists(paths.output_path + "_work/view_graph.json"));
  // Only the skeleton's pairs went into the scaffold database.
  Database skeleton(paths.output_path + "_work/component0/skeleton.db");
  EXPECT_EQ(skeleton.NumVerifiedPairs(),
            summary["skeleton_edges"].get<size_t>());
}

}  // namespace
}  // namespace hisfm
