#include "hisfm/eval/pose_evaluation.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
#include <unordered_map>

#include "hisfm/util/error.h"

namespace hisfm {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
constexpr double kRadToDeg = 180.0 / M_PI;

// Pose of one commonly registered image in both models.
struct CommonImage {
  std::string name;
  Eigen::Quaterniond model_rotation;
  Eigen::Quaterniond reference_rotation;
  Eigen::Vector3d model_center;
  Eigen::Vector3d reference_center;
};

struct Matching {
  std::vector<CommonImage> common;
  std::vector<std::string> missing;
  std::vector<std::string> unknown;
};

Matching MatchImages(const Reconstruction& model,
                     const Reconstruction& reference) {
  std::unordered_map<std::string, const Image*> model_by_name;
  model_by_name.reserve(model.images.size());
  for (const auto& [image_id, image] : model.images) {
    model_by_name.emplace(image.name, &image);
  }
  Matching matching;
  std::unordered_map<std::string, bool> in_reference;
  for (const auto& [image_id, ref_image] : reference.images) {
    in_reference.emplace(ref_image.name, true);
    const auto it = model_by_name.find(ref_image.name);
    if (it == model_by_name.end()) {
      matching.missing.push_back(ref_image.name);
      continue;
    }
    const Image& image = *it->second;
    CommonImage common;
    common.name = ref_image.name;
    common.model_rotation = image.cam_from_world.rotation.normalized();
    common.reference_rotation = ref_image.cam_from_world.rotation.normalized();
    common.model_center = image.ProjectionCenter();
    common.reference_center = ref_image.ProjectionCenter();
    matching.common.push_back(std::move(common));
  }
  for (const auto& [name, image] : model_by_name) {
    if (in_reference.count(name) == 0) matching.unknown.push_back(name);
  }
  std::sort(matching.common.begin(), matching.common.end(),
            [](const CommonImage& a, const CommonImage& b) {
              return a.name < b.name;
            });
  std::sort(matching.missing.begin(), matching.missing.end());
  std::sort(matching.unknown.begin(), matching.unknown.end());
  return matching;
}

struct PairErrors {
  std::vector<float> rotation;
  std::vector<float> translation;
  std::vector<float> pair;
};

PairErrors ComputePairErrors(const std::vector<CommonImage>& common) {
  PairErrors errors;
  const size_t n = common.size();
  const size_t num_pairs = n < 2 ? 0 : n * (n - 1) / 2;
  errors.rotation.reserve(num_pairs);
  errors.translation.reserve(num_pairs);
  errors.pair.reserve(num_pairs);
  for (size_t i = 0; i < n; ++i) {
    const CommonImage& a = common[i];
    const Eigen::Quaterniond model_inv_i = a.model_rotation.conjugate();
    const Eigen::Quaterniond reference_inv_i = a.reference_rotation.conjugate();
    for (size_t j = i + 1; j < n; ++j) {
      const CommonImage& b = common[j];
      const double rotation_error =
          RotationErrorDeg(b.model_rotation * model_inv_i,
                           b.reference_rotation * reference_inv_i);
      const double translation_error = DirectionErrorDeg(
          a.model_rotation * (b.model_center - a.model_center),
          a.reference_rotation * (b.reference_center - a.reference_center));
      errors.rotation.push_back(static_cast<float>(rotation_error));
      errors.translation.push_back(static_cast<float>(translation_error));
      errors.pair.push_back(
          static_cast<float>(std::max(rotation_error, translation_error)));
    }
  }
  return errors;
}

double Median(std::vector<float> values) {
  if (values.empty()) return kNaN;
  const size_t mid = values.size() / 2;
  std::nth_element(values.begin(), values.begin() + mid, values.end());
  const double upper = values[mid];
  if (values.size() % 2 == 1) return upper;
  const double lower =
      *std::max_element(values.begin(), values.begin() + mid);
  return 0.5 * (lower + upper);
}

double FractionWithin(const std::vector<float>& values, double threshold) {
  if (values.empty()) return 0.0;
  size_t num = 0;
  for (const float v : values) {
    if (v <= threshold) ++num;
  }
  return static_cast<double>(num) / static_cast<double>(values.size());
}

nlohmann::json NumberOrNull(double value) {
  return std::isfinite(value) ? nlohmann::json(value) : nlohmann::json();
}

std::string Percent(double fraction) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.1f%%", 100.0 * fraction);
  return buffer;
}

std::string Degrees(double value) {
  if (!std::isfinite(value)) return "n/a";
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.3f deg", value);
  return buffer;
}

std::string Fixed(double value, int digits) {
  if (!std::isfinite(value)) return "n/a";
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.*f", digits, value);
  return buffer;
}

std::string ThresholdList(const std::vector<double>& thresholds) {
  std::string out;
  for (size_t i = 0; i < thresholds.size(); ++i) {
    if (i > 0) out += "/";
    char buffer[32];
    std::snprintf(buffer, sizeof(buffer), "%g", thresholds[i]);
    out += buffer;
  }
  return out;
}

std::string FractionList(const std::vector<double>& fractions) {
  std::string out;
  for (size_t i = 0; i < fractions.size(); ++i) {
    if (i > 0) out += " / ";
    out += Percent(fractions[i]);
  }
  return out;
}

std::string NameList(const std::vector<std::string>& names, size_t max) {
  std::string out;
  for (size_t i = 0; i < names.size() && i < max; ++i) {
    if (i > 0) out += ", ";
    out += names[i];
  }
  if (names.size() > max) out += StrCat(", ... (", names.size() - max, " more)");
  return out;
}

}  // namespace

void PoseEvaluationOptions::Check() const {
  HISFM_CHECK_OPTION(pair_thresholds_deg,
                     !pair_thresholds_deg.empty(), "non-empty");
  HISFM_CHECK_OPTION(pair_thresholds_deg,
                     std::all_of(pair_thresholds_deg.begin(),
                                 pair_thresholds_deg.end(),
                                 [](double t) { return t >= 0.0; }),
                     "all >= 0.0");
  HISFM_CHECK_OPTION(verdict_threshold_deg,
                     verdict_threshold_deg >= 0.0, ">= 0.0");
  HISFM_CHECK_OPTION(min_correct_pair_fraction,
                     min_correct_pair_fraction >= 0.0 &&
                     min_correct_pair_fraction <= 1.0,
                     "in [0.0, 1.0]");
  HISFM_CHECK_OPTION(center_threshold, center_threshold > 0.0, "> 0.0");
  HISFM_CHECK_OPTION(min_correct_center_fraction,
                     min_correct_center_fraction >= 0.0 &&
                     min_correct_center_fraction <= 1.0,
                     "in [0.0, 1.0]");
  HISFM_CHECK_OPTION(min_model_size, min_model_size >= 1, ">= 1");
  alignment.Check();
}

double RotationErrorDeg(const Eigen::Quaterniond& model,
                        const Eigen::Quaterniond& reference) {
  const Eigen::Quaterniond diff =
      (model.normalized() * reference.normalized().conjugate());
  return 2.0 * std::atan2(diff.vec().norm(), std::abs(diff.w())) * kRadToDeg;
}

double DirectionErrorDeg(const Eigen::Vector3d& model,
                         const Eigen::Vector3d& reference) {
  const bool model_zero = model.squaredNorm() == 0.0;
  const bool reference_zero = reference.squaredNorm() == 0.0;
  if (model_zero && reference_zero) return 0.0;
  if (model_zero || reference_zero) return 90.0;
  return std::atan2(model.cross(reference).norm(), model.dot(reference)) *
         kRadToDeg;
}

namespace {

// The reasons joined by "; ".
std::string JoinReasons(const std::vector<std::string>& reasons) {
  std::string joined;
  for (size_t i = 0; i < reasons.size(); ++i) {
    joined += (i > 0 ? "; " : "") + reasons[i];
  }
  return joined;
}

// Enough of `eval`'s pairs within the verdict threshold.
bool PairsRight(const PoseEvaluation& eval,
                const PoseEvaluationOptions& options) {
  return eval.num_pairs > 0 &&
         eval.verdict_pair_fraction >= options.min_correct_pair_fraction;
}

// Enough of `eval`'s centres within the centre threshold (true if the
// centres could not be aligned).
bool CentersRight(const PoseEvaluation& eval,
                  const PoseEvaluationOptions& options) {
  return !eval.aligned ||
         eval.center_fraction_within >= options.min_correct_center_fraction;
}

// Why `eval` is not correct under `options` ("" if it is).
std::string VerdictReason(const PoseEvaluation& eval,
                          const PoseEvaluationOptions& options) {
  std::vector<std::string> reasons;
  if (options.require_all_registered && !eval.missing_images.empty()) {
    reasons.push_back(StrCat(eval.missing_images.size(), " of ",
                             eval.num_reference_images,
                             " reference images not registered"));
  }
  if (eval.num_pairs == 0) {
    reasons.push_back("no pair of commonly registered images");
  } else if (!PairsRight(eval, options)) {
    reasons.push_back(StrCat(Percent(eval.verdict_pair_fraction),
                             " of pairs within ",
                             ThresholdList({options.verdict_threshold_deg}),
                             " deg (needs ",
                             Percent(options.min_correct_pair_fraction), ")"));
  }
  if (!CentersRight(eval, options)) {
    reasons.push_back(StrCat(Percent(eval.center_fraction_within),
                             " of camera centres within ",
                             Percent(options.center_threshold),
                             " of the scene extent (needs ",
                             Percent(options.min_correct_center_fraction),
                             ")"));
  }
  return JoinReasons(reasons);
}

}  // namespace

PoseEvaluation EvaluateModel(const Reconstruction& model,
                             const Reconstruction& reference,
                             const PoseEvaluationOptions& options) {
  options.Check();
  const Matching matching = MatchImages(model, reference);
  PoseEvaluation eval;
  eval.num_reference_images = reference.images.size();
  eval.num_model_images = model.images.size();
  eval.num_registered = matching.common.size();
  eval.missing_images = matching.missing;
  eval.unknown_images = matching.unknown;

  const PairErrors errors = ComputePairErrors(matching.common);
  eval.num_pairs = errors.pair.size();
  eval.median_rotation_error_deg = Median(errors.rotation);
  eval.median_translation_error_deg = Median(errors.translation);
  eval.median_pair_error_deg = Median(errors.pair);
  eval.pair_thresholds_deg = options.pair_thresholds_deg;
  for (const double threshold : options.pair_thresholds_deg) {
    eval.pair_fractions_within.push_back(FractionWithin(errors.pair, threshold));
  }
  eval.verdict_pair_fraction =
      FractionWithin(errors.pair, options.verdict_threshold_deg);

  std::vector<Eigen::Vector3d> model_centers, reference_centers;
  for (const CommonImage& image : matching.common) {
    model_centers.push_back(image.model_center);
    reference_centers.push_back(image.reference_center);
    eval.image_names.push_back(image.name);
  }
  eval.image_center_errors.assign(matching.common.size(), kNaN);
  eval.image_rotation_errors_deg.assign(matching.common.size(), kNaN);
  eval.reference_extent = PointSetExtent(reference_centers);
  const SimilarityAlignment alignment = AlignSimilarityRobust(
      model_centers, reference_centers, options.alignment);
  eval.aligned = alignment.success;
  eval.median_center_error = kNaN;
  eval.mean_center_error = kNaN;
  eval.center_threshold = options.center_threshold;
  eval.center_fraction_within = kNaN;
  if (alignment.success) {
    eval.reference_from_model = alignment.target_from_source;
    eval.num_alignment_inliers = alignment.num_inliers;
    std::vector<float> center_errors;
    double sum = 0.0;
    for (size_t i = 0; i < model_centers.size(); ++i) {
      const double error = (alignment.target_from_source * model_centers[i] -
                            reference_centers[i])
                               .norm() /
                           eval.reference_extent;
      center_errors.push_back(static_cast<float>(error));
      sum += error;
      eval.image_center_errors[i] = error;
      // cam_from_reference = cam_from_model * model_from_reference.
      eval.image_rotation_errors_deg[i] = RotationErrorDeg(
          matching.common[i].model_rotation *
              alignment.target_from_source.rotation.conjugate(),
          matching.common[i].reference_rotation);
    }
    eval.median_center_error = Median(center_errors);
    eval.mean_center_error = sum / static_cast<double>(center_errors.size());
    eval.center_fraction_within =
        FractionWithin(center_errors, options.center_threshold);
  }

  eval.verdict_reason = VerdictReason(eval, options);
  eval.correct = eval.verdict_reason.empty();
  return eval;
}

MultiModelEvaluation EvaluateModels(const std::vector<Reconstruction>& models,
                                    const Reconstruction& reference,
                                    const PoseEvaluationOptions& options) {
  options.Check();
  ThrowUnless(!models.empty(), "EvaluateModels: no model to evaluate");
  MultiModelEvaluation eval;
  std::vector<size_t> pooled_counts(options.pair_thresholds_deg.size(), 0);
  std::unordered_map<std::string, bool> registered_any;
  for (size_t m = 0; m < models.size(); ++m) {
    const Matching matching = MatchImages(models[m], reference);
    eval.model_sizes.push_back(matching.common.size());
    if (matching.common.size() >= options.min_model_size) {
      ++eval.num_large_models;
    }
    if (matching.common.size() > eval.model_sizes[eval.largest_model]) {
      eval.largest_model = m;
    }
    for (const CommonImage& image : matching.common) {
      registered_any.emplace(image.name, true);
    }
    const PairErrors errors = ComputePairErrors(matching.common);
    eval.num_pairs_within_models += errors.pair.size();
    for (size_t t = 0; t < options.pair_thresholds_deg.size(); ++t) {
      for (const float e : errors.pair) {
        if (e <= options.pair_thresholds_deg[t]) ++pooled_counts[t];
      }
    }
    eval.per_model.push_back(EvaluateModel(models[m], reference, options));
  }
  for (const size_t count : pooled_counts) {
    eval.pair_fractions_within_models.push_back(
        eval.num_pairs_within_models == 0
            ? 0.0
            : static_cast<double>(count) /
                  static_cast<double>(eval.num_pairs_within_models));
  }
  eval.num_registered_any = registered_any.size();
  eval.oversplit = eval.num_large_models > 1;
  eval.largest = eval.per_model[eval.largest_model];
  eval.each_model_right = true;
  for (size_t m = 0; m < models.size(); ++m) {
    if (eval.model_sizes[m] < options.min_model_size) continue;
    if (!PairsRight(eval.per_model[m], options) ||
        !CentersRight(eval.per_model[m], options)) {
      eval.each_model_right = false;
    }
  }
  eval.correct = !eval.oversplit && eval.largest.correct;
  std::vector<std::string> reasons;
  if (eval.oversplit) {
    reasons.push_back(StrCat("split into ", eval.num_large_models,
                             " models with at least ", options.min_model_size,
                             " images"));
  }
  if (!eval.largest.correct) {
    reasons.push_back(
        StrCat(models.size() > 1 ? "largest model: " : "",
               eval.largest.verdict_reason));
  }
  eval.verdict_reason = JoinReasons(reasons);
  return eval;
}

nlohmann::json ToJson(const PoseEvaluation& e) {
  nlohmann::json j;
  j["num_reference_images"] = e.num_reference_images;
  j["num_model_images"] = e.num_model_images;
  j["num_registered"] = e.num_registered;
  j["missing_images"] = e.missing_images;
  j["unknown_images"] = e.unknown_images;
  j["num_pairs"] = e.num_pairs;
  j["median_rotation_error_deg"] = NumberOrNull(e.median_rotation_error_deg);
  j["median_translation_error_deg"] =
      NumberOrNull(e.median_translation_error_deg);
  j["median_pair_error_deg"] = NumberOrNull(e.median_pair_error_deg);
  nlohmann::json within = nlohmann::json::array();
  for (size_t i = 0; i < e.pair_thresholds_deg.size(); ++i) {
    within.push_back({{"threshold_deg", e.pair_thresholds_deg[i]},
                      {"fraction", e.pair_fractions_within[i]}});
  }
  j["pairs_within"] = within;
  j["verdict_pair_fraction"] = e.verdict_pair_fraction;
  nlohmann::json centers;
  centers["aligned"] = e.aligned;
  centers["num_alignment_inliers"] = e.num_alignment_inliers;
  centers["reference_extent"] = e.reference_extent;
  centers["median_error"] = NumberOrNull(e.median_center_error);
  centers["mean_error"] = NumberOrNull(e.mean_center_error);
  centers["threshold"] = e.center_threshold;
  centers["fraction_within"] = NumberOrNull(e.center_fraction_within);
  if (e.aligned) {
    const Sim3d& s = e.reference_from_model;
    centers["reference_from_model"] = {
        {"scale", s.scale},
        {"rotation_wxyz",
         {s.rotation.w(), s.rotation.x(), s.rotation.y(), s.rotation.z()}},
        {"translation",
         {s.translation.x(), s.translation.y(), s.translation.z()}}};
  }
  j["camera_centers"] = centers;
  nlohmann::json center_errors = nlohmann::json::array();
  nlohmann::json rotation_errors = nlohmann::json::array();
  for (size_t i = 0; i < e.image_names.size(); ++i) {
    center_errors.push_back(NumberOrNull(e.image_center_errors[i]));
    rotation_errors.push_back(NumberOrNull(e.image_rotation_errors_deg[i]));
  }
  j["per_image"] = {{"names", e.image_names},
                    {"center_error", center_errors},
                    {"rotation_error_deg", rotation_errors}};
  j["correct"] = e.correct;
  j["verdict"] = e.correct ? "correct" : "incorrect";
  j["verdict_reason"] = e.verdict_reason;
  return j;
}

nlohmann::json ToJson(const MultiModelEvaluation& e) {
  nlohmann::json j;
  j["num_models"] = e.model_sizes.size();
  j["model_sizes"] = e.model_sizes;
  j["num_large_models"] = e.num_large_models;
  j["oversplit"] = e.oversplit;
  j["each_model_right"] = e.each_model_right;
  j["largest_model"] = e.largest_model;
  j["num_registered_any"] = e.num_registered_any;
  j["num_pairs_within_models"] = e.num_pairs_within_models;
  nlohmann::json within = nlohmann::json::array();
  for (size_t i = 0; i < e.pair_fractions_within_models.size(); ++i) {
    within.push_back({{"threshold_deg", e.largest.pair_thresholds_deg.at(i)},
                      {"fraction", e.pair_fractions_within_models[i]}});
  }
  j["pairs_within_models"] = within;
  j["largest"] = ToJson(e.largest);
  nlohmann::json per_model = nlohmann::json::array();
  for (const PoseEvaluation& model : e.per_model) {
    per_model.push_back(ToJson(model));
  }
  j["per_model"] = per_model;
  j["correct"] = e.correct;
  j["verdict"] = e.correct ? "correct" : "incorrect";
  j["verdict_reason"] = e.verdict_reason;
  return j;
}

std::string FormatPoseEvaluation(const PoseEvaluation& e) {
  std::string out;
  out += StrCat("registered: ", e.num_registered, "/", e.num_reference_images,
                " reference images (model has ", e.num_model_images,
                " images)\n");
  if (!e.missing_images.empty()) {
    out += StrCat("missing: ", NameList(e.missing_images, 10), "\n");
  }
  if (!e.unknown_images.empty()) {
    out += StrCat("not in reference: ", NameList(e.unknown_images, 10), "\n");
  }
  out += StrCat("pairs: ", e.num_pairs, "; median rotation error ",
                Degrees(e.median_rotation_error_deg),
                ", median translation direction error ",
                Degrees(e.median_translation_error_deg), "\n");
  out += StrCat("pairs within ", ThresholdList(e.pair_thresholds_deg),
                " deg: ", FractionList(e.pair_fractions_within), "\n");
  if (e.aligned) {
    out += StrCat("camera centres (robust similarity alignment, ",
                  e.num_alignment_inliers, "/", e.num_registered,
                  " inliers): median error ", Fixed(e.median_center_error, 4),
                  ", mean ", Fixed(e.mean_center_error, 4),
                  " of the scene extent; ", Percent(e.center_fraction_within),
                  " within ", Percent(e.center_threshold), "\n");
  } else {
    out += "camera centres: not aligned (fewer than 3 common images)\n";
  }
  out += e.correct ? std::string("verdict: correct\n")
                   : StrCat("verdict: incorrect (", e.verdict_reason, ")\n");
  return out;
}

std::string FormatMultiModelEvaluation(const MultiModelEvaluation& e) {
  if (e.model_sizes.size() == 1) return FormatPoseEvaluation(e.largest);
  std::string sizes;
  for (size_t i = 0; i < e.model_sizes.size(); ++i) {
    sizes += StrCat(i > 0 ? ", " : "", e.model_sizes[i]);
  }
  std::string out;
  out += StrCat("models: ", e.model_sizes.size(),
                " (reference images per model: ", sizes, "); oversplit: ",
                e.oversplit ? "yes" : "no", "\n");
  out += StrCat("registered in any model: ", e.num_registered_any, "/",
                e.largest.num_reference_images, "\n");
  out += StrCat("pairs within each model: ", e.num_pairs_within_models,
                "; within ", ThresholdList(e.largest.pair_thresholds_deg),
                " deg: ", FractionList(e.pair_fractions_within_models), "\n");
  out += StrCat("largest model (#", e.largest_model, "):\n");
  std::string largest = FormatPoseEvaluation(e.largest);
  // Indent the largest model's lines, leaving out its own verdict line.
  size_t start = 0;
  while (start < largest.size()) {
    const size_t end = largest.find('\n', start);
    const std::string line = largest.substr(start, end - start);
    if (line.rfind("verdict:", 0) != 0) out += "  " + line + "\n";
    start = end + 1;
  }
  out += e.correct ? std::string("verdict: correct\n")
                   : StrCat("verdict: incorrect (", e.verdict_reason, ")\n");
  return out;
}

}  // namespace hisfm
