#include "hisfm/io/colmap_version.h"

#include <gtest/gtest.h>

#include <fstream>
#include <functional>
#include <set>
#include <sys/stat.h>

#include "hisfm/util/error.h"
#include "hisfm/util/test_util.h"

namespace hisfm {
namespace {

std::string ErrorOf(const std::function<void()>& fn) {
  try {
    fn();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

// The first line `colmap help` prints in each release (util/version.cc and
// exe/colmap.cc at the release tags; 3.10 was tagged as "3.10-dev").
TEST(ColmapVersion, ParsesTheHelpLineOfEveryRelease) {
  const std::vector<std::pair<std::string, ColmapRelease>> cases = {
      {"COLMAP 3.8 -- Structure-from-Motion and Multi-View Stereo\n"
       "              (Commit Unknown on Unknown without CUDA)\n",
       ColmapRelease::k3_8},
      {"COLMAP 3.9.1 -- Structure-from-Motion and Multi-View Stereo\n",
       ColmapRelease::k3_9},
      {"COLMAP 3.10-dev -- Structure-from-Motion and Multi-View Stereo\n",
       ColmapRelease::k3_10},
      {"COLMAP 3.11.1 -- Structure-from-Motion and Multi-View Stereo\n",
       ColmapRelease::k3_11},
      {"COLMAP 3.12.6 -- Structure-from-Motion and Multi-View Stereo\n"
       "              (Commit 0123abc on 2025-10-01 with CUDA)\n",
       ColmapRelease::k3_12},
      {"COLMAP 3.13.0 -- Structure-from-Motion and Multi-View Stereo\n",
       ColmapRelease::k3_13},
      {"COLMAP 4.0.1 (Commit 9f8e7d6 on 2026-03-15 without CUDA)\n"
       "Usage:\n",
       ColmapRelease::k4_0},
      {"COLMAP 4.1.1 (Commit 1a2b3c4 on 2026-07-17 with CUDA)\n",
       ColmapRelease::k4_1},
  };
  for (const auto& [text, release] : cases) {
    const ColmapVersion version = ParseColmapVersion(text);
    EXPECT_EQ(ColmapReleaseOf(version), release) << text;
  }
  EXPECT_EQ(ParseColmapVersion(cases[6].first).text, "4.0.1");
  EXPECT_EQ(ParseColmapVersion(cases[2].first).text, "3.10-dev");
  EXPECT_EQ(ParseColmapVersion(cases[2].first).minor, 10);
  EXPECT_EQ(KnownColmapReleases(), "3.8, 3.9, 3.10, 3.11, 3.12, 3.13, 4.0, 4.1");
}

TEST(ColmapVersion, RefusesUnknownVersionsNamingThem) {
  for (const std::string text : {"3.7", "4.2.0", "3.14-dev", "5.0"}) {
    const std::string error = ErrorOf([&] {
      ColmapReleaseOf(ParseColmapVersion("COLMAP " + text + " -- SfM"));
    });
    EXPECT_NE(error.find("unsupported COLMAP version " + text + " "),
              std::string::npos)
        << error;
    EXPECT_NE(error.find("3.8, 3.9"), std::string::npos) << error;
    EXPECT_EQ(error.find('\n'), std::string::npos);
  }
  EXPECT_NE(ErrorOf([] { ParseColmapVersion("Usage: foo"); })
                .find("no 'COLMAP <version>'"),
            std::string::npos);
  EXPECT_NE(ErrorOf([] { ParseColmapVersion("COLMAP unknown"); })
                .find("cannot read the COLMAP version 'unknown'"),
            std::string::npos);
}

// The renames hisfm depends on, as read in COLMAP's option_manager.cc and
// exe/sfm.cc at each tag.
TEST(ColmapVersion, NamesOfRenamedOptions) {
  using R = ColmapRelease;
  for (const ColmapRelease r : AllColmapReleases()) {
    const bool frames = r >= R::k3_12;
    EXPECT_EQ(ColmapOptionName(r, "mapper", "Mapper.ba_global_images_ratio"),
              frames ? "Mapper.ba_global_frames_ratio"
                     : "Mapper.ba_global_images_ratio");
    // Any release's name finds the option.
    EXPECT_EQ(ColmapOptionName(r, "mapper", "Mapper.ba_global_frames_freq"),
              frames ? "Mapper.ba_global_frames_freq"
                     : "Mapper.ba_global_images_freq");
    EXPECT_EQ(ColmapOptionName(r, "mapper", "Mapper.ba_global_points_ratio"),
              "Mapper.ba_global_points_ratio");
    EXPECT_EQ(ColmapOptionName(r, "mapper", "image_list_path"),
              r >= R::k3_13 ? "Mapper.image_list_path" : "image_list_path");
    // Only the mapper's image list moved.
    EXPECT_EQ(ColmapOptionName(r, "feature_extractor", "image_list_path"),
              "image_list_path");
    EXPECT_EQ(ColmapOptionName(r, "matches_importer",
                               "SiftMatching.min_num_inliers"),
              r >= R::k3_9 ? "TwoViewGeometry.min_num_inliers"
                           : "SiftMatching.min_num_inliers");
    EXPECT_EQ(ColmapOptionName(r, "exhaustive_matcher", "SiftMatching.use_gpu"),
              r >= R::k3_13 ? "FeatureMatching.use_gpu"
                            : "SiftMatching.use_gpu");
    EXPECT_EQ(ColmapOptionName(r, "feature_extractor",
                               "SiftExtraction.num_threads"),
              r >= R::k3_13 ? "FeatureExtraction.num_threads"
                            : "SiftExtraction.num_threads");
    EXPECT_EQ(ColmapOptionName(r, "mapper", "Mapper.random_seed"),
              r >= R::k3_13 ? "Mapper.random_seed" : "");
    EXPECT_EQ(ColmapOptionName(r, "bundle_adjuster", "BundleAdjustment.use_gpu"),
              r >= R::k4_0    ? "BundleAdjustmentCeres.use_gpu"
              : r >= R::k3_11 ? "BundleAdjustment.use_gpu"
                              : "");
    // Not in the table: unchanged.
    EXPECT_EQ(ColmapOptionName(r, "mapper", "Mapper.tri_ignore_two_view_tracks"),
              "Mapper.tri_ignore_two_view_tracks");
  }
  // Every row names every release it exists in, and no name is shared by two
  // rows of the same command.
  std::set<std::pair<std::string, std::string>> names;
  for (const ColmapOptionNames& row : ColmapOptionTable()) {
    ASSERT_EQ(row.names.size(), static_cast<size_t>(kNumColmapReleases));
    std::set<std::string> own(row.names.begin(), row.names.end());
    own.erase("");
    EXPECT_FALSE(own.empty());
    for (const std::string& name : own) {
      EXPECT_TRUE(names.insert({row.command, name}).second) << name;
    }
  }
}

TEST(ColmapVersion, TranslatesArgumentListsAndKeepsTheFirstOfARepeat) {
  const std::vector<std::string> args = {
      "mapper", "--database_path", "db", "--image_list_path", "list.txt",
      // The user's flag under the new name, then hisfm's default under 3.8's.
      "--Mapper.ba_global_frames_ratio", "2",
      "--Mapper.ba_global_images_ratio", "1.4",
      "--Mapper.ba_global_images_freq=1000000000",
      "--Mapper.tri_ignore_two_view_tracks", "0"};
  const std::vector<std::string> v38 =
      TranslateColmapArguments(ColmapRelease::k3_8, args);
  EXPECT_EQ(v38, (std::vector<std::string>{
                     "mapper", "--database_path", "db", "--image_list_path",
                     "list.txt", "--Mapper.ba_global_images_ratio", "2",
                     "--Mapper.ba_global_images_freq=1000000000",
                     "--Mapper.tri_ignore_two_view_tracks", "0"}));
  const std::vector<std::string> v41 =
      TranslateColmapArguments(ColmapRelease::k4_1, args);
  EXPECT_EQ(v41, (std::vector<std::string>{
                     "mapper", "--database_path", "db",
                     "--Mapper.image_list_path", "list.txt",
                     "--Mapper.ba_global_frames_ratio", "2",
                     "--Mapper.ba_global_frames_freq=1000000000",
                     "--Mapper.tri_ignore_two_view_tracks", "0"}));
  // A newer option for an older colmap: one line naming option and releases.
  const std::string error = ErrorOf([] {
    TranslateColmapArguments(ColmapRelease::k3_11,
                             {"mapper", "--Mapper.random_seed", "1"});
  });
  EXPECT_EQ(error,
            "COLMAP 3.11 has no option --Mapper.random_seed (mapper; it "
            "exists in COLMAP 3.13 to 4.1)");
  EXPECT_TRUE(TranslateColmapArguments(ColmapRelease::k4_0, {}).empty());
}

TEST(ColmapVersion, MapperEndOfLoopBehaviour) {
  EXPECT_FALSE(MapperAdjustsGloballyWhenNothingToRegister(ColmapRelease::k3_8));
  EXPECT_FALSE(
      MapperAdjustsGloballyWhenNothingToRegister(ColmapRelease::k3_13));
  EXPECT_TRUE(MapperAdjustsGloballyWhenNothingToRegister(ColmapRelease::k4_0));
  EXPECT_TRUE(MapperAdjustsGloballyWhenNothingToRegister(ColmapRelease::k4_1));
}

// A stand-in `colmap` that prints a version line.
std::string WriteFakeColmap(const TempDir& tmp, const std::string& line) {
  const std::string path = tmp / "colmap";
  std::ofstream(path) << "#!/bin/sh\necho '" << line << "'\n";
  chmod(path.c_str(), 0755);
  return path;
}

TEST(ColmapVersion, ProbeReadsTheVersionOfTheExecutable) {
  TempDir tmp;
  const std::string colmap = WriteFakeColmap(
      tmp, "COLMAP 4.0.1 (Commit 9f8e7d6 on 2026-03-15 without CUDA)");
  const ColmapProbe probe = ProbeColmap(colmap);
  EXPECT_EQ(probe.release, ColmapRelease::k4_0);
  EXPECT_EQ(probe.version.text, "4.0.1");
  // Remembered for the path until asked again.
  WriteFakeColmap(tmp, "COLMAP 4.7 (Commit 0 on 2030-01-01)");
  EXPECT_EQ(ProbeColmap(colmap).release, ColmapRelease::k4_0);
  EXPECT_NE(ErrorOf([&] { ProbeColmap(colmap, true); })
                .find("unsupported COLMAP version 4.7 "),
            std::string::npos);
  EXPECT_NE(ErrorOf([&] { ProbeColmap(tmp / "missing"); })
                .find("colmap not found"),
            std::string::npos);
  const std::string other = WriteFakeColmap(tmp, "hello");
  EXPECT_NE(ErrorOf([&] { ProbeColmap(other, true); })
                .find("does not look like COLMAP"),
            std::string::npos);
}

}  // namespace
}  // namespace hisfm
