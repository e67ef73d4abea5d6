// Checks of a COLMAP sparse model beyond its file format: what would make a
// pose evaluation, a report or colmap itself compute with NaN or index out
// of range. The readers of hisfm/io/model.h (ReadModel, ReadModelBinary,
// ReadModelText) refuse a model with any problem, naming the first one;
// `hisfm check_model` lists them all. (The file format itself, truncation,
// unknown camera models and images naming missing cameras, is checked while
// reading; allocations are bounded by the file's size.)
//
// Checks:
//   cameras:  width and height positive; as many parameters as the model
//             has, finite, focal lengths positive.
//   images:   camera present; rotation quaternion finite and not zero;
//             translation finite; name not empty, without line breaks or
//             other control characters or spaces at either end, unique; 2D
//             points finite; a 2D point's 3D point present in points3D.
//   points3D: id not COLMAP's "no point" (2^64 - 1); position and error
//             finite; every track element names an image of the model, a 2D
//             point of that image (index in range) that observes this point.
#pragma once

#include <string>
#include <vector>

#include "hisfm/io/model.h"

namespace hisfm {

/// One problem of a model.
struct ModelProblem {
  /// The file's record type: "cameras", "images" or "points3D".
  std::string file;
  /// The record: "camera 1", "image 5", "point 1234".
  std::string id;
  /// What is wrong.
  std::string message;
};

/// "file, id: message".
std::string FormatModelProblem(const ModelProblem& problem);

struct ModelValidationOptions {
  /// Stop after this many problems (0: find every problem). Records are
  /// checked cameras first, then images, then points, each in id order.
  int max_problems = 0;

  /// Throws hisfm::Error naming an invalid option.
  void Check() const;
};

/// The problems of `model` (empty if none). Time and memory linear in the
/// model's size.
std::vector<ModelProblem> ValidateModel(
    const Reconstruction& model, const ModelValidationOptions& options = {});

/// Throws hisfm::Error with one line naming `path` and the model's first
/// problem unless it has none.
void RequireValidModel(const Reconstruction& model, const std::string& path);

}  // namespace hisfm
