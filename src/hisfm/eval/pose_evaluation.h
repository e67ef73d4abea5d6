// Gauge-free evaluation of reconstructed camera poses against a reference
// model of the same images (matched by image name).
//
// The HiSfM paper (Sec. IV, Table I) judges reconstructions of ambiguous
// scenes as correct, incorrect or oversplit by inspection. This makes the
// judgement measurable: relative-pose errors between all pairs of commonly
// registered images are invariant to the similarity gauge of either model,
// and a folded or duplicated structure shows up as a large fraction of pairs
// with errors far above the noise. Camera-centre errors are measured after a
// robust similarity alignment (similarity_alignment.h) and are part of the
// verdict: along a straight street, a stretch of collinear cameras that
// slides, shrinks or stretches along its line keeps every relative direction,
// and only the centres show it.
//
// For images i, j with cam_from_world rotations R_i, R_j and centres C_i,
// C_j:
//   relative rotation   R_ij = R_j R_i^T (cam_j_from_cam_i);
//   rotation error      angle(R_ij_model R_ij_reference^T);
//   translation error   angle between the unit baselines R_i (C_j - C_i)
//                       (camera j's centre seen from camera i's frame);
//   pair error          max(rotation error, translation error).
#pragma once

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "hisfm/eval/similarity_alignment.h"
#include "hisfm/io/model.h"

namespace hisfm {

struct PoseEvaluationOptions {
  /// Pair-error thresholds (degrees) whose fractions of pairs are reported.
  std::vector<double> pair_thresholds_deg = {2.0, 5.0, 10.0};
  /// Threshold (degrees) used by the verdict.
  double verdict_threshold_deg = 5.0;
  /// The verdict needs at least this fraction of pairs within
  /// verdict_threshold_deg.
  double min_correct_pair_fraction = 0.95;
  /// The verdict needs every reference image to be registered.
  bool require_all_registered = true;
  /// An image's camera centre is right when, after the robust alignment, it
  /// lies within this fraction of the reference extent of its reference
  /// centre (the alignment's own inlier threshold by default). Relative
  /// directions cannot show a stretch of collinear cameras that slides,
  /// shrinks or flips along a straight street; the centres do.
  double center_threshold = 0.05;
  /// The verdict needs at least this fraction of the commonly registered
  /// images with their centres within center_threshold (0 turns the check
  /// off). Not checked when the centres cannot be aligned: fewer than three
  /// common images, or reference centres without extent.
  double min_correct_center_fraction = 0.95;
  /// EvaluateModels: models with at least this many reference images count
  /// towards over-splitting. (The paper ignores extra models under 16 images
  /// on Heinly et al.'s larger scenes; the yan2017 scenes have 21 to 64.)
  size_t min_model_size = 3;
  /// Robust alignment of the camera centres.
  SimilarityAlignmentOptions alignment;

  /// Throws hisfm::Error if an option is out of range.
  void Check() const;
};

/// The errors of one model's poses against the reference.
struct PoseEvaluation {
  /// Images in the reference and in the model.
  size_t num_reference_images = 0;
  size_t num_model_images = 0;
  /// Reference images that the model registered (matched by name).
  size_t num_registered = 0;
  /// Names of reference images the model lacks, sorted.
  std::vector<std::string> missing_images;
  /// Names of model images absent from the reference, sorted.
  std::vector<std::string> unknown_images;

  /// Pairs of commonly registered images that were evaluated.
  size_t num_pairs = 0;
  /// Medians over the pairs (NaN without pairs).
  double median_rotation_error_deg = 0.0;
  double median_translation_error_deg = 0.0;
  double median_pair_error_deg = 0.0;
  /// options.pair_thresholds_deg and the fraction of pairs whose pair error
  /// is within each (0 without pairs).
  std::vector<double> pair_thresholds_deg;
  std::vector<double> pair_fractions_within;
  /// Fraction of pairs within options.verdict_threshold_deg.
  double verdict_pair_fraction = 0.0;

  /// Camera centres after the robust similarity alignment of the model onto
  /// the reference (needs three common images).
  bool aligned = false;
  Sim3d reference_from_model;
  size_t num_alignment_inliers = 0;
  /// Extent of the common reference camera centres (PointSetExtent).
  double reference_extent = 0.0;
  /// Centre errors as fractions of reference_extent (NaN if not aligned).
  double median_center_error = 0.0;
  double mean_center_error = 0.0;
  /// The commonly registered images, in the model's image id order: the
  /// order of the per-image errors.
  std::vector<std::string> image_names;
  /// Per image, after the alignment: the centre error as a fraction of
  /// reference_extent, and the rotation error (degrees) of the aligned
  /// camera (NaN if not aligned).
  std::vector<double> image_center_errors;
  std::vector<double> image_rotation_errors_deg;
  /// options.center_threshold, and the fraction of the commonly registered
  /// images whose centre error is within it (NaN if not aligned).
  double center_threshold = 0.0;
  double center_fraction_within = 0.0;

  /// All reference images registered (if required), enough pairs within
  /// the verdict threshold and, if aligned, enough camera centres within
  /// the centre threshold.
  bool correct = false;
  /// Why the verdict is "incorrect" (empty if correct).
  std::string verdict_reason;
};

/// Evaluates `model` against `reference`; image names link the two.
PoseEvaluation EvaluateModel(const Reconstruction& model,
                             const Reconstruction& reference,
                             const PoseEvaluationOptions& options);

/// The evaluation of a reconstruction that came out as several models.
struct MultiModelEvaluation {
  /// Number of reference images in each model, in the given order.
  std::vector<size_t> model_sizes;
  /// Models with at least options.min_model_size reference images.
  size_t num_large_models = 0;
  /// More than one large model: the scene was split.
  bool oversplit = false;
  /// Index of the model with the most reference images (first on ties).
  size_t largest_model = 0;
  /// The largest model against the reference.
  PoseEvaluation largest;
  /// Each model against the reference (pairs within that model only).
  std::vector<PoseEvaluation> per_model;
  /// Pairs within each model, pooled over all models.
  size_t num_pairs_within_models = 0;
  std::vector<double> pair_fractions_within_models;
  /// Reference images registered in at least one model.
  size_t num_registered_any = 0;
  /// Every model with at least options.min_model_size reference images is
  /// right within itself: enough of its pairs within the verdict threshold
  /// and, if aligned, of its centres within the centre threshold (the
  /// images it lacks aside). An oversplit result with this true is split
  /// but not folded.
  bool each_model_right = false;
  /// Not oversplit and the largest model is correct.
  bool correct = false;
  std::string verdict_reason;
};

/// Evaluates several models of one scene against the reference (models
/// must be non-empty in number; one model gives the same verdict as
/// EvaluateModel).
MultiModelEvaluation EvaluateModels(const std::vector<Reconstruction>& models,
                                    const Reconstruction& reference,
                                    const PoseEvaluationOptions& options);

/// JSON forms (NaN values become null).
nlohmann::json ToJson(const PoseEvaluation& evaluation);
nlohmann::json ToJson(const MultiModelEvaluation& evaluation);

/// Human-readable summary, several lines ending with "verdict: correct" or
/// "verdict: incorrect (reason)".
std::string FormatPoseEvaluation(const PoseEvaluation& evaluation);
std::string FormatMultiModelEvaluation(const MultiModelEvaluation& evaluation);

/// Rotation error (degrees) of a relative rotation estimate against its
/// reference: the angle of model * reference^-1.
double RotationErrorDeg(const Eigen::Quaterniond& model,
                        const Eigen::Quaterniond& reference);
/// Angle (degrees) between two directions; 0 if both are zero vectors and
/// 90 if only one is.
double DirectionErrorDeg(const Eigen::Vector3d& model,
                         const Eigen::Vector3d& reference);

}  // namespace hisfm
