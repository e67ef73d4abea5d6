#include "hisfm/io/colmap_version.h"

#include <fcntl.h>
#include <unistd.h>

#include <cctype>
#include <cstring>
#include <filesystem>
#include <map>
#include <mutex>
#include <set>

#include "hisfm/util/child_process.h"
#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"
#include "hisfm/util/interrupt.h"

namespace hisfm {
namespace {

struct ReleaseInfo {
  ColmapRelease release;
  int major;
  int minor;
};

constexpr ReleaseInfo kReleases[kNumColmapReleases] = {
    {ColmapRelease::k3_8, 3, 8},   {ColmapRelease::k3_9, 3, 9},
    {ColmapRelease::k3_10, 3, 10}, {ColmapRelease::k3_11, 3, 11},
    {ColmapRelease::k3_12, 3, 12}, {ColmapRelease::k3_13, 3, 13},
    {ColmapRelease::k4_0, 4, 0},   {ColmapRelease::k4_1, 4, 1},
};

// One row of the table: the release from which each name holds (until the
// next entry), oldest first; "" is no option.
struct NameChange {
  ColmapRelease since;
  const char* name;
};

ColmapOptionNames Row(const std::string& command,
                      std::initializer_list<NameChange> changes) {
  ColmapOptionNames row;
  row.command = command;
  row.names.assign(kNumColmapReleases, "");
  for (const NameChange& change : changes) {
    for (int r = static_cast<int>(change.since); r < kNumColmapReleases; ++r) {
      row.names[r] = change.name;
    }
  }
  return row;
}

// An option named alike in every release.
ColmapOptionNames Same(const std::string& command, const char* name) {
  return Row(command, {{ColmapRelease::k3_8, name}});
}

std::vector<ColmapOptionNames> BuildTable() {
  using R = ColmapRelease;
  return {
      // colmap mapper (exe/sfm.cc RunMapper; option_manager.cc
      // AddMapperOptions).
      Same("", "database_path"),
      Same("", "image_path"),
      Same("", "input_path"),
      Same("", "output_path"),
      Row("mapper", {{R::k3_8, "image_list_path"},
                     {R::k3_13, "Mapper.image_list_path"}}),
      Same("", "Mapper.min_num_matches"),
      Same("", "Mapper.min_model_size"),
      Row("", {{R::k3_8, "Mapper.ba_global_images_ratio"},
               {R::k3_12, "Mapper.ba_global_frames_ratio"}}),
      Row("", {{R::k3_8, "Mapper.ba_global_images_freq"},
               {R::k3_12, "Mapper.ba_global_frames_freq"}}),
      Same("", "Mapper.ba_global_points_ratio"),
      Same("", "Mapper.ba_global_points_freq"),
      Same("", "Mapper.ba_global_max_refinements"),
      Same("", "Mapper.ba_global_function_tolerance"),
      Same("", "Mapper.ba_local_max_refinements"),
      Same("", "Mapper.ba_global_max_num_iterations"),
      Row("", {{R::k3_8, "Mapper.snapshot_images_freq"},
               {R::k3_12, "Mapper.snapshot_frames_freq"}}),
      Row("", {{R::k3_8, "Mapper.fix_existing_images"},
               {R::k3_12, "Mapper.fix_existing_frames"}}),
      Row("", {{R::k3_8, "Mapper.local_ba_min_tri_angle"},
               {R::k3_13, "Mapper.ba_local_min_tri_angle"}}),
      Row("", {{R::k3_13, "Mapper.random_seed"}}),
      Row("", {{R::k3_13, "Mapper.max_runtime_seconds"}}),
      // colmap point_triangulator.
      Same("point_triangulator", "clear_points"),
      // colmap bundle_adjuster (AddBundleAdjustmentOptions; use_gpu and
      // gpu_index from 3.11).
      Row("", {{R::k3_8, "BundleAdjustment.max_num_iterations"},
               {R::k4_0, "BundleAdjustmentCeres.max_num_iterations"}}),
      Row("", {{R::k3_8, "BundleAdjustment.function_tolerance"},
               {R::k4_0, "BundleAdjustmentCeres.function_tolerance"}}),
      Row("", {{R::k3_8, "BundleAdjustment.gradient_tolerance"},
               {R::k4_0, "BundleAdjustmentCeres.gradient_tolerance"}}),
      Row("", {{R::k3_8, "BundleAdjustment.parameter_tolerance"},
               {R::k4_0, "BundleAdjustmentCeres.parameter_tolerance"}}),
      Row("", {{R::k3_11, "BundleAdjustment.use_gpu"},
               {R::k4_0, "BundleAdjustmentCeres.use_gpu"}}),
      Row("", {{R::k3_11, "BundleAdjustment.gpu_index"},
               {R::k4_0, "BundleAdjustmentCeres.gpu_index"}}),
      // colmap feature_extractor (exe/feature.cc; AddExtractionOptions,
      // AddFeatureExtractionOptions from 3.13).
      Same("feature_extractor", "image_list_path"),
      Same("", "ImageReader.camera_model"),
      Same("", "ImageReader.single_camera"),
      Same("", "ImageReader.single_camera_per_image"),
      Same("", "SiftExtraction.max_num_features"),
      Row("", {{R::k3_8, "SiftExtraction.use_gpu"},
               {R::k3_13, "FeatureExtraction.use_gpu"}}),
      Row("", {{R::k3_8, "SiftExtraction.num_threads"},
               {R::k3_13, "FeatureExtraction.num_threads"}}),
      Row("", {{R::k3_8, "SiftExtraction.gpu_index"},
               {R::k3_13, "FeatureExtraction.gpu_index"}}),
      Row("", {{R::k3_8, "SiftExtraction.max_image_size"},
               {R::k4_0, "FeatureExtraction.max_image_size"}}),
      // Matchers and matches_importer (AddMatchingOptions,
      // AddFeatureMatchingOptions and AddTwoViewGeometryOptions from 3.13).
      Same("", "ExhaustiveMatching.block_size"),
      Same("matches_importer", "match_list_path"),
      Same("matches_importer", "match_type"),
      Row("", {{R::k3_8, "SiftMatching.use_gpu"},
               {R::k3_13, "FeatureMatching.use_gpu"}}),
      Row("", {{R::k3_8, "SiftMatching.num_threads"},
               {R::k3_13, "FeatureMatching.num_threads"}}),
      Row("", {{R::k3_8, "SiftMatching.gpu_index"},
               {R::k3_13, "FeatureMatching.gpu_index"}}),
      Row("", {{R::k3_8, "SiftMatching.guided_matching"},
               {R::k3_13, "FeatureMatching.guided_matching"}}),
      Row("", {{R::k3_8, "SiftMatching.max_num_matches"},
               {R::k3_13, "FeatureMatching.max_num_matches"}}),
      Row("", {{R::k3_8, "SiftMatching.min_num_inliers"},
               {R::k3_9, "TwoViewGeometry.min_num_inliers"}}),
      Row("", {{R::k3_8, "SiftMatching.max_error"},
               {R::k3_9, "TwoViewGeometry.max_error"}}),
      Row("", {{R::k3_8, "SiftMatching.min_inlier_ratio"},
               {R::k3_9, "TwoViewGeometry.min_inlier_ratio"}}),
      Row("", {{R::k3_8, "SiftMatching.confidence"},
               {R::k3_9, "TwoViewGeometry.confidence"}}),
      Row("", {{R::k3_8, "SiftMatching.max_num_trials"},
               {R::k3_9, "TwoViewGeometry.max_num_trials"}}),
      Row("", {{R::k3_8, "SiftMatching.multiple_models"},
               {R::k3_9, "TwoViewGeometry.multiple_models"}}),
      Row("", {{R::k3_8, "SiftMatching.compute_relative_pose"},
               {R::k3_9, "TwoViewGeometry.compute_relative_pose"}}),
  };
}

// The row of `option` (a name of any release) for `command`, or nullptr.
const ColmapOptionNames* FindRow(const std::string& command,
                                 const std::string& option) {
  for (const ColmapOptionNames& row : ColmapOptionTable()) {
    if (!row.command.empty() && row.command != command) continue;
    for (const std::string& name : row.names) {
      if (name == option) return &row;
    }
  }
  return nullptr;
}

// The releases that have the option of `row`, as "3.13 to 4.1".
std::string ReleasesWith(const ColmapOptionNames& row) {
  int first = -1, last = -1;
  for (int r = 0; r < kNumColmapReleases; ++r) {
    if (row.names[r].empty()) continue;
    if (first < 0) first = r;
    last = r;
  }
  if (first < 0) return "no release";
  const std::string a = ColmapReleaseName(static_cast<ColmapRelease>(first));
  const std::string b = ColmapReleaseName(static_cast<ColmapRelease>(last));
  return first == last ? a : StrCat(a, " to ", b);
}

}  // namespace

std::vector<ColmapRelease> AllColmapReleases() {
  std::vector<ColmapRelease> out;
  for (const ReleaseInfo& info : kReleases) out.push_back(info.release);
  return out;
}

std::string ColmapReleaseName(ColmapRelease release) {
  const ReleaseInfo& info = kReleases[static_cast<int>(release)];
  return StrCat(info.major, ".", info.minor);
}

std::string KnownColmapReleases() {
  std::string out;
  for (const ReleaseInfo& info : kReleases) {
    out += StrCat(out.empty() ? "" : ", ", info.major, ".", info.minor);
  }
  return out;
}

ColmapVersion ParseColmapVersion(const std::string& help_output) {
  const std::string kPrefix = "COLMAP ";
  size_t pos = help_output.find(kPrefix);
  ThrowUnless(pos != std::string::npos,
              "no 'COLMAP <version>' in the output of colmap help");
  pos += kPrefix.size();
  size_t end = pos;
  while (end < help_output.size() &&
         !std::isspace(static_cast<unsigned char>(help_output[end]))) {
    ++end;
  }
  ColmapVersion version;
  version.text = help_output.substr(pos, end - pos);
  // major.minor[.patch][-suffix]
  const char* s = version.text.c_str();
  char* rest = nullptr;
  const long major = std::strtol(s, &rest, 10);
  const bool has_minor = rest != s && *rest == '.' &&
                         std::isdigit(static_cast<unsigned char>(rest[1]));
  ThrowUnless(has_minor && std::isdigit(static_cast<unsigned char>(s[0])),
              StrCat("cannot read the COLMAP version '", version.text,
                     "' in the output of colmap help"));
  const long minor = std::strtol(rest + 1, nullptr, 10);
  version.major = static_cast<int>(major);
  version.minor = static_cast<int>(minor);
  return version;
}

ColmapRelease ColmapReleaseOf(const ColmapVersion& version) {
  for (const ReleaseInfo& info : kReleases) {
    if (info.major == version.major && info.minor == version.minor) {
      return info.release;
    }
  }
  throw Error(StrCat("unsupported COLMAP version ", version.text,
                     " (hisfm knows ", KnownColmapReleases(),
                     "; set --colmap_path to one of them)"));
}

const std::vector<ColmapOptionNames>& ColmapOptionTable() {
  static const std::vector<ColmapOptionNames> kTable = BuildTable();
  return kTable;
}

std::string ColmapOptionName(ColmapRelease release, const std::string& command,
                             const std::string& option) {
  const ColmapOptionNames* row = FindRow(command, option);
  if (row == nullptr) return option;
  return row->names[static_cast<int>(release)];
}

std::vector<std::string> TranslateColmapArguments(
    ColmapRelease release, const std::vector<std::string>& args) {
  if (args.empty()) return args;
  const std::string& command = args[0];
  std::vector<std::string> out = {command};
  // Options seen, by their row (or their own name when not in the table).
  std::set<std::string> seen;
  for (size_t i = 1; i < args.size(); ++i) {
    const std::string& arg = args[i];
    if (arg.rfind("--", 0) != 0) {
      out.push_back(arg);
      continue;
    }
    const size_t eq = arg.find('=');
    const std::string option =
        arg.substr(2, eq == std::string::npos ? std::string::npos : eq - 2);
    // The value: after '=', or the next argument unless it is an option.
    const bool inline_value = eq != std::string::npos;
    const bool next_value = !inline_value && i + 1 < args.size() &&
                            args[i + 1].rfind("--", 0) != 0;
    const ColmapOptionNames* row = FindRow(command, option);
    const std::string key =
        row ? StrCat(row - ColmapOptionTable().data()) : option;
    if (!seen.insert(key).second) {
      if (next_value) ++i;
      continue;
    }
    std::string name = option;
    if (row != nullptr) {
      name = row->names[static_cast<int>(release)];
      ThrowUnless(!name.empty(),
                  StrCat("COLMAP ", ColmapReleaseName(release),
                         " has no option --", option, " (", command,
                         "; it exists in COLMAP ", ReleasesWith(*row), ")"));
    }
    out.push_back(inline_value ? StrCat("--", name, arg.substr(eq))
                               : "--" + name);
    if (next_value) out.push_back(args[++i]);
  }
  return out;
}

bool MapperAdjustsGloballyWhenNothingToRegister(ColmapRelease release) {
  return release >= ColmapRelease::k4_0;
}

ColmapProbe ProbeColmap(const std::string& colmap_path, bool refresh) {
  static std::mutex mutex;
  static std::map<std::string, ColmapProbe> cache;
  {
    std::lock_guard<std::mutex> lock(mutex);
    const auto it = cache.find(colmap_path);
    if (!refresh && it != cache.end()) return it->second;
  }
  char path[] = "/tmp/hisfm-colmap-check-XXXXXX";
  const int fd = mkstemp(path);
  ThrowUnless(fd >= 0, "cannot create a temporary file in /tmp");
  std::vector<std::string> env = CurrentEnvironment();
  // colmap's own log files (glog) stay out of /tmp.
  env.push_back("GLOG_logtostderr=1");
  int spawn_error = 0;
  const int status =
      RunChildProcess({colmap_path, "help"}, env, fd, &spawn_error);
  close(fd);
  const std::string head = TailOfFile(path, 1000);
  unlink(path);
  ThrowIfInterrupted();
  ThrowUnless(status >= 0,
              StrCat("colmap not found: cannot run '", colmap_path, "' (",
                     std::strerror(spawn_error),
                     "); install it with scripts/setup.sh or set "
                     "--colmap_path"));
  const size_t pos = head.find("COLMAP");
  ThrowUnless(pos != std::string::npos,
              StrCat("'", colmap_path, "' does not look like COLMAP"));
  ColmapProbe probe;
  const size_t end = head.find(" | ", pos);
  probe.line = head.substr(pos, end == std::string::npos ? end : end - pos);
  probe.version = ParseColmapVersion(head.substr(pos));
  probe.release = ColmapReleaseOf(probe.version);
  std::lock_guard<std::mutex> lock(mutex);
  cache[colmap_path] = probe;
  return probe;
}

}  // namespace hisfm
