// Writes a synthetic scene as a COLMAP workspace:
//   DIR/database.db        cameras, images, keypoints, matches and
//                          two_view_geometries (COLMAP 3.8 layout)
//   DIR/ground_truth/      the true model (cameras.bin, images.bin,
//                          points3D.bin), same image ids and names
//   DIR/images/            empty (`colmap mapper` wants an existing folder)
//   DIR/synth_summary.json the options and the counts of SynthDatasetSummary;
//                          family scenes add "family" (the parameters used,
//                          drawn ones included) and "observed_clutter_ratio"
//   DIR/pair_labels.txt    the composition of every verified pair's inliers:
//                          after '#' comment lines, one line per pair in
//                          two_view_geometries with at least min_num_inliers
//                          inliers, in pair order:
//                            NAME1 NAME2 INLIERS TRUE DOPPELGANGER RANDOM
//                          INLIERS = TRUE + DOPPELGANGER + RANDOM: inliers
//                          observing the same scene point in both images,
//                          two copies of repeated content, and random wrong
//                          matches. A single inlier is true exactly when its
//                          two keypoints carry the same point3D_id in
//                          ground_truth/.
// With two_view_geometry = "colmap" the raw matches are verified by
// `colmap matches_importer --match_type raw` (its log is kept as
// DIR/matches_importer.log); otherwise they are verified directly
// (hisfm/synth/synthetic_matches.h).
#pragma once

#include <string>
#include <vector>

#include "hisfm/synth/synth_options.h"
#include "hisfm/synth/synthetic_matches.h"

namespace hisfm {

/// What was written.
struct SynthDatasetSummary {
  size_t num_images = 0;
  size_t num_keypoints = 0;
  /// Points of the ground truth (observed by at least two images).
  size_t num_points3D = 0;
  /// Pairs with at least one putative match.
  size_t num_matched_pairs = 0;
  /// Pairs in two_view_geometries with at least min_num_inliers inliers.
  size_t num_verified_pairs = 0;
  /// Verified doppelganger pairs: direct mode, the kept epipolar geometry is
  /// a doppelganger one (family scenes: most inliers are doppelganger
  /// matches, SynthVerification::MostlyDoppelganger); colmap mode, most of
  /// COLMAP's inliers are doppelganger matches (IsDoppelgangerInlierSet).
  size_t num_doppelganger_pairs = 0;
  /// Total number of inlier matches of the verified pairs.
  size_t num_inlier_matches = 0;
  /// Family scenes: keypoints of unique clutter per keypoint of repeated
  /// content (facades or object), over all images (0 for other scenes).
  double observed_clutter_ratio = 0.0;
  /// Seconds spent generating images, matching and verifying (with database
  /// writes), and in total.
  double scene_seconds = 0.0;
  double pairs_seconds = 0.0;
  double total_seconds = 0.0;
};

/// Generates options.scene and writes it into `output_path`, which must not
/// exist or be an empty folder (the result appears atomically). Throws
/// hisfm::Error on invalid options, I/O errors or a failing colmap call.
SynthDatasetSummary WriteSyntheticDataset(const SynthOptions& options,
                                          const std::string& output_path);

/// The kinds of a verified pair's inliers, looked up in the pair's labelled
/// putative matches (inliers that are not among them count as random).
struct InlierLabelCounts {
  size_t num_true = 0;
  size_t num_doppelganger = 0;
  size_t num_random = 0;
};
InlierLabelCounts CountInlierLabels(const SynthPairMatches& matches,
                                    const std::vector<FeatureMatch>& inliers);

/// Whether a verified pair is a doppelganger: most of its inliers (given by
/// the pair's labelled putative matches) relate different points.
bool IsDoppelgangerInlierSet(const SynthPairMatches& matches,
                             const std::vector<FeatureMatch>& inliers);

/// One line of pair_labels.txt: a verified pair's inliers by kind.
struct PairLabel {
  std::string name1;
  std::string name2;
  size_t num_inliers = 0;
  size_t num_true = 0;
  size_t num_doppelganger = 0;
  size_t num_random = 0;
  /// Whether the pair's doppelganger inliers outnumber its true ones.
  bool IsDoppelganger() const { return num_doppelganger > num_true; }
};

/// Reads a pair_labels.txt that WriteSyntheticDataset wrote, in file order.
/// Throws hisfm::Error if the file cannot be read or a line is malformed
/// (not exactly two names and four non-negative counts, or counts that do
/// not add up).
std::vector<PairLabel> ReadPairLabels(const std::string& path);

}  // namespace hisfm
