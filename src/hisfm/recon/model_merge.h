// Merging sub-models that share registered images, and joining models that
// share none through the matches of verified pairs between them
// (MergeThroughMatches).
//
// When incremental SfM cannot register the next image of a scaffold (a tree
// bridge that is true but too weak to register across), colmap mapper starts
// a new model from the unregistered images, and the new model often starts
// from, or later registers, an image of the first one; a model re-seeded on
// the images left unregistered (hierarchical_mapper.h) shares their
// registered neighbours by construction. A shared image ties the two models
// together: its pose in each fixes the rotation and translation between
// them, and the depths, in that image, of the 3D points its keypoints
// observe in both fix the scale (their median ratio). Each shared image
// gives one such similarity; the one that most of the shared points agree
// with (within a fraction of their depth) is kept, as a minimal sample of
// RANSAC (Fischler and Bolles, 1981) is scored by its consensus. This is the
// merge step of COLMAP's hierarchical mapper (Schonberger and Frahm,
// "Structure-from-Motion Revisited", CVPR 2016), which merges the
// reconstructions of clusters through their common images, applied here to
// the sub-models of one component: without it, the smaller sub-models are
// dropped and their images are left to stages whose edges may not reach
// them.
#pragma once

#include <optional>
#include <set>
#include <vector>

#include "hisfm/io/database.h"
#include "hisfm/io/model.h"

namespace hisfm {

struct ModelMergeOptions {
  /// A sub-model is merged only if at least this many shared points (a
  /// keypoint of a shared image observing a 3D point in both models) agree
  /// with the similarity. The shared image's two poses already fix all but
  /// the scale; on the synthetic families a single shared image gave 12 to
  /// 26 such points, with depth ratios within 2% of their median. 6 merged
  /// a street re-seeded through the one image at a crossing with 7 of 9
  /// agreeing (crossing_streets_1000_s7, tuning) at the wrong scale: 73.6%
  /// of the final model's pairs within 5 degrees, where each street apart
  /// is right.
  int min_inliers = 8;
  /// ... and at least this share of all shared points. At 0.5, a sub-model
  /// of 38 images merged through one shared image with 12 of 23 points
  /// agreeing (crossing_streets_1000_s7, tuning) stretched its stretch of
  /// street five times: hidden from the pair directions, 42 images up to
  /// 380 m off. Right merges seen on the tuning instances agreed on 79% to
  /// 100%; 0.7 refuses the wrong one, and the largest model of that run is
  /// then right by its centres too (docs/decisions.md, fifteenth session).
  double min_inlier_ratio = 0.7;
  /// A shared point agrees when the mapped point lies within this fraction
  /// of its depth (in the shared image of the model merged into; for
  /// MergeThroughMatches, in the pair's image of that model) of the model's
  /// point.
  double max_relative_error = 0.1;
  /// MergeInto: refit the similarity by least squares to the agreeing points
  /// of all shared images (rather than keep the one shared image's pose
  /// that scored best), repeated while no fewer points agree, up to
  /// num_refits times.
  bool refine_similarity = true;
  /// Most least-squares refits of refine_similarity.
  int num_refits = 5;

  /// Throws hisfm::Error if an option is out of range.
  void Check() const;
};

/// How one sub-model was merged.
struct ModelMergeStep {
  /// Index of the sub-model in the input list.
  size_t model = 0;
  /// Registered images of the sub-model.
  size_t num_images = 0;
  /// Registered images it shares with the merged model (with the same
  /// number of keypoints in both; 0 for MergeThroughMatches).
  size_t num_common_images = 0;
  /// MergeThroughMatches: the pairs between the two models whose matches
  /// gave correspondences.
  size_t num_pairs = 0;
  /// Shared points: keypoints of shared images that observe a 3D point in
  /// both models (for MergeThroughMatches: matches whose two keypoints
  /// observe a 3D point, one in each model).
  size_t num_correspondences = 0;
  /// Shared (or matched) points that agree with the best similarity.
  size_t num_inliers = 0;
  /// True if a model has a rig of several sensors, or only one of the two
  /// has rigs and frames: such models are not merged.
  bool rigs_refused = false;
  /// True if it was merged.
  bool merged = false;
};

/// The result of merging a list of sub-models.
struct ModelMergeResult {
  /// The base sub-model with every sub-model merged into it that could be;
  /// in the base's frame.
  Reconstruction model;
  /// Index of the base sub-model (the frame of `model`).
  size_t base = 0;
  /// One step per other sub-model: those merged, in the order they were
  /// merged, then those left out.
  std::vector<ModelMergeStep> steps;
  /// Number of sub-models merged into the base.
  size_t NumMerged() const;
};

/// Maps `other` into `model`'s frame through their shared images and adds
/// it: images only in `other` get their poses (and, with COLMAP 3.12's
/// single-camera rigs, their frames) moved, the 3D points of the shared
/// points that agree are joined into one track (a point of `model` takes
/// one point of `other`, the first found; another that corresponds to it
/// is added as a point of its own, so that no track observes an image
/// twice), the others of `other` are added as new points (without the
/// observations of keypoints that already observe a point of `model`;
/// points left with fewer than two observations are dropped), and cameras and rigs not in `model` are added (a camera in
/// both keeps `model`'s intrinsics). Returns the step's counts; `model` is
/// changed only if merged. Both models must come from one database (image,
/// camera and keypoint ids mean the same) and hold finite values, as
/// ReadModel guarantees.
ModelMergeStep MergeInto(const Reconstruction& other,
                         const ModelMergeOptions& options,
                         Reconstruction* model);

/// A verified pair and its inlier matches, as the database stores them
/// (idx1 indexes the keypoints of pair.image_id1).
struct PairMatches {
  ImagePair pair;
  std::vector<FeatureMatch> matches;
};

/// Maps `other` into `model`'s frame through verified pairs between an
/// image of each (the two models need share no image) and adds it as
/// MergeInto does. A match whose keypoints observe a 3D point in both
/// models is a correspondence of the two points; the similarity is the
/// robust fit of the correspondences (AlignSimilarityRobust, fixed seed)
/// under which a point agrees when it lands within max_relative_error of its
/// depth, in the pair's image of `model`, of the model's point. The counts
/// and thresholds are MergeInto's (min_inliers, min_inlier_ratio); points
/// that agree are joined into one track. Pairs whose two images are not one
/// in each model are ignored. Where MergeInto needs a common image, this
/// joins models that 2D-2D matches alone tie together (3D-3D
/// correspondences through the matches, fitted by Umeyama's least squares
/// inside RANSAC): a model that a street crossing or a weak bridge split off
/// is joined through the pairs the hierarchy verified between them.
ModelMergeStep MergeThroughMatches(const Reconstruction& other,
                                   const std::vector<PairMatches>& pairs,
                                   const ModelMergeOptions& options,
                                   Reconstruction* model);

/// The index of the model with most registered images (the first on a
/// tie; 0 for an empty list).
size_t LargestModelIndex(const std::vector<Reconstruction>& models);

/// Starts from the base model (`base`, or else the one with most registered
/// images, the first on a tie) and merges the others into it, repeating
/// over those left while any merges (a chain of sub-models joins through
/// each other). `models` must not be empty.
ModelMergeResult MergeModels(const std::vector<Reconstruction>& models,
                             const ModelMergeOptions& options = {},
                             std::optional<size_t> base = std::nullopt);

/// Removes the images `image_ids` from `model`: their images, their
/// observations in the points' tracks, the points left with fewer than two
/// observations (and the other images' references to them), and the frames
/// whose images (camera data) were all removed. Ids not in the model are
/// ignored. Throws hisfm::Error if a frame holds removed and kept images (a
/// rig of several cameras), leaving `model` unchanged.
void RemoveImages(const std::set<ImageId>& image_ids, Reconstruction* model);

/// `models` without the images of `base` and of the larger ones among them
/// (and without images left observing no point), largest first, those
/// keeping at least `min_images` images: models that can be written beside
/// `base` with no image in two of them. A model with rigs of several
/// cameras that shares images is left out.
std::vector<Reconstruction> DisjointModels(const Reconstruction& base,
                                           std::vector<Reconstruction> models,
                                           size_t min_images);

/// The sub-models of `models` that `result` (MergeModels) left out, as they
/// are, in the order of result.steps: what a run reconstructed but could not
/// join (DisjointModels makes them fit beside the merged model).
std::vector<Reconstruction> UnmergedModels(
    const std::vector<Reconstruction>& models, const ModelMergeResult& result);

}  // namespace hisfm
