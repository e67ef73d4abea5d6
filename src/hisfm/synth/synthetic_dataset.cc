#include "hisfm/synth/synthetic_dataset.h"

#include <fcntl.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <unordered_map>

#include "hisfm/io/colmap_version.h"
#include "hisfm/io/database.h"
#include "hisfm/io/database_writer.h"
#include "hisfm/io/model.h"
#include "hisfm/util/child_process.h"
#include "hisfm/util/parallel.h"
#include "hisfm/util/error.h"
#include "hisfm/util/interrupt.h"
#include "hisfm/util/file_util.h"
#include "hisfm/util/logging.h"
#include "hisfm/util/timer.h"

namespace fs = std::filesystem;

namespace hisfm {
namespace {

// Keypoints of clutter per keypoint of repeated content.
double ObservedClutterRatio(const SyntheticScene& scene) {
  size_t clutter = 0, repeated = 0;
  for (const SynthImage& image : scene.images) {
    for (const SynthFeature& feature : image.features) {
      if (feature.point_index == kNoScenePoint) continue;
      const ScenePoint& p = scene.layout.points[feature.point_index];
      if (p.on_object) ++repeated;
      if (p.clutter) ++clutter;
    }
  }
  return repeated > 0 ? static_cast<double>(clutter) / repeated : 0.0;
}

nlohmann::json FamilyJson(const SynthFamilyOptions& family) {
  nlohmann::json json;
  json["period"] = family.period;
  json["camera_spacing"] = family.camera_spacing;
  json["facade_distance"] = family.facade_distance;
  json["relief_depth"] = family.relief_depth;
  json["clutter_density"] = family.clutter_density;
  json["block_length"] = family.block_length;
  json["ground_density"] = family.ground_density;
  json["unique_pattern"] = family.unique_pattern;
  json["position_jitter"] = family.position_jitter;
  json["rotation_jitter"] = family.rotation_jitter;
  json["block_aspect"] = family.block_aspect;
  json["view_angle"] = family.view_angle;
  json["symmetry_order"] = family.symmetry_order;
  json["ring_radius"] = family.ring_radius;
  json["descriptor_noise"] = family.descriptor_noise;
  return json;
}

// pair_labels.txt (see the header).
class PairLabelWriter {
 public:
  PairLabelWriter(const SyntheticScene& scene, const std::string& path)
      : scene_(scene), path_(path), out_(path) {
    ThrowUnless(out_.good(), StrCat("cannot write ", path));
    out_ << "# Inliers of each verified pair by kind (hisfm synth).\n"
         << "# NAME1 NAME2 INLIERS TRUE DOPPELGANGER RANDOM\n";
  }
  void Write(const ImagePair& pair, size_t num_true, size_t num_doppelganger,
             size_t num_random) {
    out_ << scene_.images[pair.image_id1 - 1].name << ' '
         << scene_.images[pair.image_id2 - 1].name << ' '
         << num_true + num_doppelganger + num_random << ' ' << num_true << ' '
         << num_doppelganger << ' ' << num_random << '\n';
  }
  void Close() {
    out_.close();
    ThrowUnless(!out_.fail(), StrCat("cannot write ", path_));
  }

 private:
  const SyntheticScene& scene_;
  std::string path_;
  std::ofstream out_;
};

void WriteSceneTables(const SyntheticScene& scene, DatabaseWriter* writer) {
  DatabaseCamera camera;
  camera.camera_id = scene.camera.camera_id;
  camera.model_id = scene.camera.model_id;
  camera.width = scene.camera.width;
  camera.height = scene.camera.height;
  camera.params = scene.camera.params;
  // Known intrinsics: COLMAP verifies pairs as calibrated (essential matrix).
  camera.prior_focal_length = true;
  writer->WriteCamera(camera);
  for (const SynthImage& image : scene.images) {
    DatabaseImage db_image;
    db_image.image_id = image.image_id;
    db_image.name = image.name;
    db_image.camera_id = camera.camera_id;
    writer->WriteImage(db_image);
    writer->WriteKeypoints(image.image_id, image.KeypointMatrix());
  }
}

// Runs `colmap matches_importer --match_type raw` on the written database.
void VerifyWithColmap(const SynthOptions& options, const std::string& folder,
                      const std::string& match_list_path) {
  const std::string log_path = (fs::path(folder) / "matches_importer.log").string();
  // Options under the names of the colmap that runs.
  const ColmapRelease release = ProbeColmap(options.colmap_path).release;
  std::vector<std::string> argv = {options.colmap_path};
  for (std::string& arg : TranslateColmapArguments(release, {
      "matches_importer",
      "--database_path",
      (fs::path(folder) / "database.db").string(),
      "--match_list_path",
      match_list_path,
      "--match_type",
      "raw",
      "--SiftMatching.use_gpu",
      "0",
      "--SiftMatching.min_num_inliers",
      StrCat(options.min_num_inliers),
      "--SiftMatching.max_error",
      StrCat(options.max_error),
      "--SiftMatching.min_inlier_ratio",
      StrCat(options.min_inlier_ratio),
      "--SiftMatching.num_threads",
      StrCat(NumWorkerThreads(options.num_threads))})) {
    argv.push_back(std::move(arg));
  }
  std::string command;
  for (const std::string& a : argv) command += (command.empty() ? "" : " ") + a;
  HISFM_LOG_INFO("Running {}", command);
  const int fd = open(log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  ThrowUnless(fd >= 0, StrCat("cannot write log file ", log_path));
  int start_error = 0;
  // colmap dies with hisfm, however hisfm ends.
  const int code = RunChildProcess(argv, CurrentEnvironment(), fd, &start_error);
  close(fd);
  if (code == 0) return;
  ThrowIfInterrupted();
  ThrowUnless(code >= 0, StrCat("colmap not found: cannot run '",
                                options.colmap_path, "'"));
  // The folder is temporary and removed on failure: the log's last line
  // goes into the message.
  throw Error(StrCat("colmap matches_importer failed (exit ", code,
                     "): ", TailOfFile(log_path, 1)));
}

}  // namespace

InlierLabelCounts CountInlierLabels(const SynthPairMatches& matches,
                                    const std::vector<FeatureMatch>& inliers) {
  std::unordered_map<uint64_t, int> label_of;
  label_of.reserve(matches.matches.size());
  for (size_t m = 0; m < matches.matches.size(); ++m) {
    const FeatureMatch& fm = matches.matches[m];
    label_of[(static_cast<uint64_t>(fm.idx1) << 32) | fm.idx2] = matches.labels[m];
  }
  InlierLabelCounts counts;
  for (const FeatureMatch& fm : inliers) {
    auto it = label_of.find((static_cast<uint64_t>(fm.idx1) << 32) | fm.idx2);
    if (it == label_of.end() || it->second == kOutlierMatchLabel) {
      ++counts.num_random;
    } else if (it->second == 0) {
      ++counts.num_true;
    } else {
      ++counts.num_doppelganger;
    }
  }
  return counts;
}

bool IsDoppelgangerInlierSet(const SynthPairMatches& matches,
                             const std::vector<FeatureMatch>& inliers) {
  const InlierLabelCounts counts = CountInlierLabels(matches, inliers);
  return counts.num_doppelganger > counts.num_true;
}

SynthDatasetSummary WriteSyntheticDataset(const SynthOptions& options,
                                          const std::string& output_path) {
  options.Check();
  const SynthTwoViewMode mode = ParseSynthTwoViewMode(options.two_view_geometry);
  Timer total_timer;
  SynthDatasetSummary summary;
  AtomicDirectory output(output_path);
  const std::string folder = output.path();
  const std::string database_path = (fs::path(folder) / "database.db").string();

  LogHeading(StrCat("Synthetic scene ", options.scene, " (", options.num_images,
                    " images, seed ", options.seed, ")"));
  Timer timer;
  const SyntheticScene scene = GenerateScene(options);
  summary.num_images = scene.images.size();
  summary.num_keypoints = scene.NumKeypoints();
  {
    const Reconstruction ground_truth = BuildGroundTruthModel(scene);
    summary.num_points3D = ground_truth.NumPoints3D();
    const std::string gt_path = (fs::path(folder) / "ground_truth").string();
    fs::create_directories(gt_path);
    WriteModelBinary(ground_truth, gt_path);
  }
  fs::create_directories(fs::path(folder) / "images");
  summary.scene_seconds = timer.ElapsedSeconds();
  HISFM_LOG_INFO("{} images, {} keypoints, {} ground-truth points ({:.1f} s)",
                 summary.num_images, summary.num_keypoints,
                 summary.num_points3D, summary.scene_seconds);

  if (scene.layout.family) {
    summary.observed_clutter_ratio = ObservedClutterRatio(scene);
  }

  timer.Restart();
  const size_t min_inliers = static_cast<size_t>(options.min_num_inliers);
  PairLabelWriter labels(scene, (fs::path(folder) / "pair_labels.txt").string());
  if (mode == SynthTwoViewMode::kDirect) {
    DatabaseWriter writer(database_path);
    WriteSceneTables(scene, &writer);
    ForEachSynthPair(scene, /*verify=*/true, [&](const SynthPair& pair) {
      ++summary.num_matched_pairs;
      if (options.write_matches) {
        writer.WriteMatches(pair.matches.pair, pair.matches.matches);
      }
      const SynthVerification& v = pair.verification;
      if (!v.verified || v.geometry.inlier_matches.size() < min_inliers) return;
      writer.WriteTwoViewGeometry(v.geometry);
      labels.Write(v.geometry.pair, v.num_true_inliers,
                   v.num_doppelganger_inliers, v.num_random_inliers);
      ++summary.num_verified_pairs;
      summary.num_inlier_matches += v.geometry.inlier_matches.size();
      if (scene.layout.family ? v.MostlyDoppelganger() : v.IsDoppelganger()) {
        ++summary.num_doppelganger_pairs;
      }
    });
    writer.Close();
  } else {
    {
      DatabaseWriter writer(database_path);
      WriteSceneTables(scene, &writer);
      writer.Close();
    }
    // Raw matches of pairs that can reach min_num_inliers, as a text file
    // (image names, then one "idx1 idx2" line per match, then a blank line).
    const std::string list_path = (fs::path(folder) / "raw_matches.txt").string();
    std::unordered_map<PairId, SynthPairMatches> labelled;
    {
      std::ofstream list(list_path);
      ThrowUnless(list.good(), StrCat("cannot write ", list_path));
      ForEachSynthPair(scene, /*verify=*/false, [&](const SynthPair& pair) {
        ++summary.num_matched_pairs;
        const SynthPairMatches& m = pair.matches;
        if (m.matches.size() < min_inliers) return;
        list << scene.images[m.pair.image_id1 - 1].name << ' '
             << scene.images[m.pair.image_id2 - 1].name << '\n';
        for (const FeatureMatch& fm : m.matches) {
          list << fm.idx1 << ' ' << fm.idx2 << '\n';
        }
        list << '\n';
        labelled[ImagePairToPairId(m.pair.image_id1, m.pair.image_id2)] = m;
      });
      ThrowUnless(list.good(), StrCat("cannot write ", list_path));
    }
    VerifyWithColmap(options, folder, list_path);
    fs::remove(list_path);
    const Database database(database_path);
    for (const VerifiedPair& vp : database.ReadVerifiedPairs(
             static_cast<uint32_t>(min_inliers))) {
      ++summary.num_verified_pairs;
      summary.num_inlier_matches += vp.num_inliers;
      const TwoViewGeometry g =
          database.ReadTwoViewGeometry(vp.pair.image_id1, vp.pair.image_id2);
      auto it = labelled.find(ImagePairToPairId(vp.pair.image_id1, vp.pair.image_id2));
      InlierLabelCounts counts;
      if (it != labelled.end()) {
        counts = CountInlierLabels(it->second, g.inlier_matches);
      } else {
        counts.num_random = g.inlier_matches.size();
      }
      labels.Write(vp.pair, counts.num_true, counts.num_doppelganger,
                   counts.num_random);
      if (counts.num_doppelganger > counts.num_true) {
        ++summary.num_doppelganger_pairs;
      }
    }
  }
  labels.Close();
  summary.pairs_seconds = timer.ElapsedSeconds();
  HISFM_LOG_INFO(
      "{} matched pairs, {} verified pairs ({} doppelganger), {} inlier "
      "matches ({:.1f} s)",
      summary.num_matched_pairs, summary.num_verified_pairs,
      summary.num_doppelganger_pairs, summary.num_inlier_matches,
      summary.pairs_seconds);

  summary.total_seconds = total_timer.ElapsedSeconds();
  nlohmann::json json;
  json["scene"] = options.scene;
  json["num_images"] = options.num_images;
  json["seed"] = options.seed;
  json["two_view_geometry"] = options.two_view_geometry;
  json["camera_model"] = options.camera_model;
  json["object_density"] = options.object_density;
  json["background_density"] = options.background_density;
  json["street_block_houses"] = options.street_block_houses;
  json["keypoint_noise"] = options.keypoint_noise;
  json["outlier_ratio"] = options.outlier_ratio;
  json["max_view_angle"] = options.max_view_angle;
  json["num_keypoints"] = summary.num_keypoints;
  json["num_points3D"] = summary.num_points3D;
  json["num_matched_pairs"] = summary.num_matched_pairs;
  json["num_verified_pairs"] = summary.num_verified_pairs;
  json["num_doppelganger_pairs"] = summary.num_doppelganger_pairs;
  json["num_inlier_matches"] = summary.num_inlier_matches;
  json["seconds"] = summary.total_seconds;
  if (scene.layout.family) {
    json["family"] = FamilyJson(scene.layout.family_options);
    json["observed_clutter_ratio"] = summary.observed_clutter_ratio;
  }
  WriteFileAtomically((fs::path(folder) / "synth_summary.json").string(),
                      json.dump(2) + "\n");
  output.Commit();
  HISFM_LOG_INFO("Wrote {} ({:.1f} s)", output_path, summary.total_seconds);
  return summary;
}

std::vector<PairLabel> ReadPairLabels(const std::string& path) {
  std::ifstream in(path);
  ThrowUnless(in.good(), StrCat("cannot read ", path));
  std::vector<PairLabel> labels;
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream fields(line);
    PairLabel l;
    long long counts[4] = {-1, -1, -1, -1};
    fields >> l.name1 >> l.name2 >> counts[0] >> counts[1] >> counts[2] >>
        counts[3];
    const bool six_fields = !fields.fail() && (fields >> std::ws).eof();
    const bool non_negative = counts[0] >= 0 && counts[1] >= 0 &&
                              counts[2] >= 0 && counts[3] >= 0;
    ThrowUnless(six_fields && non_negative &&
                    counts[0] == counts[1] + counts[2] + counts[3],
                StrCat(path, ": not a line of pair labels: ", line));
    l.num_inliers = static_cast<size_t>(counts[0]);
    l.num_true = static_cast<size_t>(counts[1]);
    l.num_doppelganger = static_cast<size_t>(counts[2]);
    l.num_random = static_cast<size_t>(counts[3]);
    labels.push_back(std::move(l));
  }
  ThrowUnless(!in.bad(), StrCat("cannot read ", path));
  return labels;
}

}  // namespace hisfm
