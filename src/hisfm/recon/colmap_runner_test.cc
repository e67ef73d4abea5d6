// The mapper against stand-in `colmap` executables, one per COLMAP release,
// that accept only the option names of that release (read in COLMAP's
// sources at its tag: exe/sfm.cc and controllers/option_manager.cc) and
// refuse a repeated option, as boost::program_options does.
#include "hisfm/recon/colmap_runner.h"

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <filesystem>
#include <fstream>

#include "hisfm/io/colmap_version.h"
#include "hisfm/io/model.h"
#include "hisfm/recon/hierarchical_mapper.h"
#include "hisfm/synth/synthetic_dataset.h"
#include "hisfm/util/error.h"
#include "hisfm/util/string_util.h"
#include "hisfm/util/test_util.h"

namespace fs = std::filesystem;

namespace hisfm {
namespace {

struct FakeRelease {
  ColmapRelease release;
  std::string help_line;
  // Mapper.ba_global_frames_* (3.12 on) instead of *_images_*.
  bool frames;
  // --Mapper.image_list_path (3.13 on) instead of --image_list_path.
  bool mapper_image_list;
};

const std::vector<FakeRelease>& FakeReleases() {
  using R = ColmapRelease;
  static const std::vector<FakeRelease> kReleases = {
      {R::k3_8,
       "COLMAP 3.8 -- Structure-from-Motion and Multi-View Stereo", false,
       false},
      {R::k3_9,
       "COLMAP 3.9.1 -- Structure-from-Motion and Multi-View Stereo", false,
       false},
      {R::k3_10,
       "COLMAP 3.10-dev -- Structure-from-Motion and Multi-View Stereo",
       false, false},
      {R::k3_11,
       "COLMAP 3.11.1 -- Structure-from-Motion and Multi-View Stereo", false,
       false},
      {R::k3_12,
       "COLMAP 3.12.6 -- Structure-from-Motion and Multi-View Stereo", true,
       false},
      {R::k3_13,
       "COLMAP 3.13.0 -- Structure-from-Motion and Multi-View Stereo", true,
       true},
      {R::k4_0, "COLMAP 4.0.1 (Commit 9f8e7d6 on 2026-03-15 without CUDA)",
       true, true},
      {R::k4_1, "COLMAP 4.1.1 (Commit 1a2b3c4 on 2026-07-17 without CUDA)",
       true, true},
  };
  return kReleases;
}

// The `colmap mapper` options of a release that the mapper may pass.
std::string MapperFlags(const FakeRelease& r) {
  std::string flags =
      "database_path image_path input_path output_path Mapper.min_model_size "
      "Mapper.ba_global_points_ratio Mapper.ba_global_points_freq "
      "Mapper.ba_global_max_refinements Mapper.ba_global_function_tolerance "
      "Mapper.ba_local_max_refinements Mapper.tri_ignore_two_view_tracks "
      "Mapper.ba_global_max_num_iterations ";
  flags += r.frames ? "Mapper.ba_global_frames_ratio Mapper.ba_global_frames_freq "
                    : "Mapper.ba_global_images_ratio Mapper.ba_global_images_freq ";
  flags += r.mapper_image_list ? "Mapper.image_list_path" : "image_list_path";
  return flags;
}

// Writes a stand-in colmap that prints `help_line`, checks the options of
// mapper and bundle_adjuster against the release's, and "reconstructs" by
// copying the model folder `model` (into output/0, or into output when
// continuing from --input_path).
std::string WriteFakeColmap(const std::string& path,
                            const std::string& help_line,
                            const std::string& mapper_flags,
                            const std::string& model) {
  std::ofstream out(path);
  out << "#!/bin/bash\n"
      << "cmd=\"$1\"; shift\n"
      << "if [ \"$cmd\" = help ]; then echo '" << help_line
      << "'; echo 'Usage:'; exit 0; fi\n"
      << "case \"$cmd\" in\n"
      << "  mapper) allowed=\" " << mapper_flags << " \" ;;\n"
      << "  bundle_adjuster) allowed=\" input_path output_path \" ;;\n"
      << "  *) echo \"unknown command $cmd\" >&2; exit 1 ;;\n"
      << "esac\n"
      << "declare -A opt\n"
      << "while [ $# -gt 0 ]; do\n"
      << "  name=\"${1#--}\"\n"
      << "  case \"$allowed\" in *\" $name \"*) ;; *)\n"
      << "    echo \"unrecognised option '--$name'\" >&2; exit 2 ;; esac\n"
      << "  if [ -n \"${opt[$name]+x}\" ]; then\n"
      << "    echo \"option '--$name' cannot be specified more than once\" >&2\n"
      << "    exit 2\n"
      << "  fi\n"
      << "  opt[$name]=\"$2\"; shift 2\n"
      << "done\n"
      << "if [ \"$cmd\" = mapper ] && [ -z \"${opt[input_path]}\" ]; then\n"
      << "  mkdir -p \"${opt[output_path]}/0\"\n"
      << "  cp '" << model << "'/* \"${opt[output_path]}/0/\"\n"
      << "elif [ \"$cmd\" = mapper ]; then\n"
      << "  cp '" << model << "'/* \"${opt[output_path]}/\"\n"
      << "else\n"
      << "  cp \"${opt[input_path]}\"/* \"${opt[output_path]}/\"\n"
      << "fi\n";
  out.close();
  chmod(path.c_str(), 0755);
  return path;
}

// The `mapper` command lines of a work folder's colmap log.
std::vector<std::string> MapperCommands(const std::string& log_path) {
  std::ifstream log(log_path);
  std::vector<std::string> commands;
  for (std::string line; std::getline(log, line);) {
    if (line.rfind("$ ", 0) == 0 && line.find(" mapper ") != std::string::npos) {
      commands.push_back(line + " ");
    }
  }
  return commands;
}

class ColmapReleasesTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    scene_ = new TempDir("hisfm-colmap-releases");
    SynthOptions synth;
    synth.scene = "symmetric2";
    synth.num_images = 16;
    synth.seed = 1;
    WriteSyntheticDataset(synth, *scene_ / "scene");
  }
  static void TearDownTestSuite() {
    delete scene_;
    scene_ = nullptr;
  }

  static MapperPaths Paths(const TempDir& tmp) {
    MapperPaths paths;
    paths.database_path = *scene_ / "scene/database.db";
    paths.image_path = *scene_ / "scene/images";
    paths.output_path = tmp / "out";
    return paths;
  }

  static TempDir* scene_;
};

TempDir* ColmapReleasesTest::scene_ = nullptr;

// The ground truth as COLMAP 3.12 and later write it: one rig per camera
// and one frame per image (what COLMAP makes of an older model).
std::string WriteModelWithRigs(const std::string& ground_truth,
                               const std::string& folder) {
  Reconstruction model = ReadModel(ground_truth);
  model.rigs.emplace();
  model.frames.emplace();
  for (const auto& [camera_id, camera] : model.cameras) {
    Rig rig;
    rig.rig_id = camera_id;
    rig.ref_sensor = SensorId{SensorType::kCamera, camera_id};
    model.rigs->push_back(rig);
  }
  for (const auto& [image_id, image] : model.images) {
    Frame frame;
    frame.frame_id = image_id;
    frame.rig_id = image.camera_id;
    frame.rig_from_world = image.cam_from_world;
    frame.data.push_back({SensorId{SensorType::kCamera, image.camera_id},
                          image_id});
    model.frames->push_back(frame);
  }
  fs::create_directories(folder);
  WriteModelBinary(model, folder);
  return folder;
}

TEST_F(ColmapReleasesTest, MapperRunsWithTheOptionNamesOfEveryRelease) {
  for (const FakeRelease& r : FakeReleases()) {
    SCOPED_TRACE(r.help_line);
    TempDir tmp;
    // 3.12 and later write rigs and frames into every model.
    const bool rigs = r.release >= ColmapRelease::k3_12;
    const std::string model =
        rigs ? WriteModelWithRigs(*scene_ / "scene/ground_truth",
                                  tmp / "colmap_model")
             : *scene_ / "scene/ground_truth";
    HierarchicalMapperOptions options;
    options.colmap.colmap_path =
        WriteFakeColmap(tmp / "colmap", r.help_line, MapperFlags(r), model);
    // A user's flag under the newest name, and one the table does not list.
    options.mapper_args = {"--Mapper.ba_global_frames_ratio", "1.7",
                           "--Mapper.tri_ignore_two_view_tracks", "0"};
    const nlohmann::json summary = RunHierarchicalMapper(Paths(tmp), options);
    EXPECT_EQ(summary["registered_images"], 16);
    EXPECT_EQ(summary["colmap_version"],
              ParseColmapVersion(r.help_line).text);
    EXPECT_EQ(ReadModel(tmp / "out/0").NumRegImages(), 16u);
    // The model hisfm writes keeps colmap's rigs and frames.
    EXPECT_EQ(fs::exists(tmp / "out/0/rigs.bin"), rigs);
    EXPECT_EQ(fs::exists(tmp / "out/0/frames.bin"), rigs);
    if (rigs) {
      for (const char* file : {"rigs.bin", "frames.bin", "images.bin"}) {
        EXPECT_EQ(FileFingerprint(tmp / "out/0/" + std::string(file)),
                  FileFingerprint(model + "/" + file))
            << file;
      }
    }
    const std::vector<std::string> commands =
        MapperCommands(tmp / "out_work/component0/colmap.log");
    ASSERT_EQ(commands.size(), 2u) << "scaffold and attach";
    const std::string ratio = r.frames ? "--Mapper.ba_global_frames_ratio "
                                       : "--Mapper.ba_global_images_ratio ";
    const std::string freq = r.frames ? "--Mapper.ba_global_frames_freq "
                                      : "--Mapper.ba_global_images_freq ";
    const std::string list = r.mapper_image_list ? " --Mapper.image_list_path "
                                                 : " --image_list_path ";
    for (const std::string& c : commands) {
      // The user's value, once, under this release's name.
      EXPECT_EQ(CountOccurrences(c, ratio), 1u) << c;
      EXPECT_NE(c.find(ratio + "1.7 "), std::string::npos) << c;
      EXPECT_NE(c.find(list), std::string::npos) << c;
      EXPECT_NE(c.find("--Mapper.tri_ignore_two_view_tracks 0 "),
                std::string::npos)
          << c;
    }
    // The attach run's schedule: no periodic global adjustment.
    EXPECT_NE(commands[1].find(freq + "1000000000 "), std::string::npos)
        << commands[1];
  }
}

TEST_F(ColmapReleasesTest, UnknownReleaseIsRefusedBeforeAnyWork) {
  for (const std::string line :
       {"COLMAP 3.7 -- Structure-from-Motion and Multi-View Stereo",
        "COLMAP 4.2.0 (Commit 0 on 2027-01-01 without CUDA)"}) {
    TempDir tmp;
    HierarchicalMapperOptions options;
    options.colmap.colmap_path =
        WriteFakeColmap(tmp / "colmap", line, "", *scene_ / "scene/ground_truth");
    std::string error;
    try {
      RunHierarchicalMapper(Paths(tmp), options);
    } catch (const Error& e) {
      error = e.what();
    }
    const std::string version = line.substr(7, line.find(' ', 7) - 7);
    EXPECT_NE(error.find("unsupported COLMAP version " + version + " "),
              std::string::npos)
        << error;
    EXPECT_EQ(error.find('\n'), std::string::npos);
    EXPECT_FALSE(fs::exists(tmp / "out"));
    EXPECT_FALSE(fs::exists(tmp / "out_work"));
  }
}

// A flag the release lacks is refused in one line, naming both.
TEST_F(ColmapReleasesTest, OptionMissingFromTheReleaseIsNamed) {
  const FakeRelease& r38 = FakeReleases()[0];
  TempDir tmp;
  HierarchicalMapperOptions options;
  options.colmap.colmap_path = WriteFakeColmap(
      tmp / "colmap", r38.help_line, MapperFlags(r38),
      *scene_ / "scene/ground_truth");
  EXPECT_THROW(RunColmap(options.colmap, {"mapper", "--Mapper.random_seed", "1"},
                         tmp / "log.txt"),
               Error);
  try {
    RunColmap(options.colmap, {"mapper", "--Mapper.random_seed", "1"},
              tmp / "log.txt");
  } catch (const Error& e) {
    EXPECT_EQ(std::string(e.what()),
              "COLMAP 3.8 has no option --Mapper.random_seed (mapper; it "
              "exists in COLMAP 3.13 to 4.1)");
  }
}

TEST(ColmapRunner, TheInstalledColmapIsAKnownRelease) {
  if (!ColmapAvailable()) GTEST_SKIP() << "colmap is not installed";
  const std::string line = CheckColmapAvailable(ColmapRunnerOptions());
  EXPECT_EQ(line.rfind("COLMAP ", 0), 0u) << line;
  // Debian 12's package.
  EXPECT_EQ(ProbeColmap("colmap").release, ColmapRelease::k3_8);
}

}  // namespace
}  // namespace hisfm
