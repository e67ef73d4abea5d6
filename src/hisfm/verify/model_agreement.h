// Does a verified pair agree with a reconstruction of its two images? Each
// inlier whose keypoint has a 3D point in the model is transferred: the point
// is projected into the other image and must land near the matched keypoint.
// A doppelganger pair fails this even when its epipolar geometry agrees with
// the model (a repeated facade shifted along the baseline keeps the epipolar
// lines), since its matches point at the wrong copy of the structure. This is
// the missing-correspondence argument of Cui and Tan (ICCV 2015) and the
// reconstruction-level conflict of Heinly et al. (ECCV 2014), asked of one
// pair against a model that does not contain it.
#pragma once

#include <vector>

#include "hisfm/io/database.h"
#include "hisfm/io/model.h"
#include "hisfm/util/types.h"

namespace hisfm {

struct ModelAgreementOptions {
  /// A match agrees when its transferred point lands within this share of
  /// the image diagonal of the matched keypoint (0.02: 26 pixels at
  /// 1024x768), loose enough for the drift of a long chain.
  double max_transfer_error = 0.02;
  /// A judged pair agrees when at least this share of its testable matches
  /// agree.
  double min_agreeing_share = 0.5;
  /// Pairs with fewer testable matches (both directions counted: a keypoint
  /// with a 3D point that projects in front of the other camera) are not
  /// judged.
  int min_testable = 10;
  /// Threads that look for the pairs that cannot agree.
  int num_threads = 2;

  /// Throws hisfm::Error if an option is out of range.
  void Check() const;
};

/// The transfer test of one pair.
struct PairAgreement {
  /// The pair judged.
  ImagePair pair;
  /// Matches with a 3D point that projects in front of the other camera
  /// (each direction counted).
  int num_testable = 0;
  /// Those landing within max_transfer_error.
  int num_agreeing = 0;
  /// Whether the pair had enough testable matches to be judged.
  bool judged = false;
  /// Judged and agreeing (false when not judged).
  bool agrees = false;
  /// The pair's inlier matches (oriented as stored) that agree: at least one
  /// of their two transfers is testable, and each testable one lands within
  /// max_transfer_error.
  std::vector<FeatureMatch> agreeing_matches;
};

/// Judges the `pairs` that have both images registered in `model` (others
/// are left out of the result), reading their inlier matches from
/// `database`. A pair whose images cannot see enough of each other's 3D
/// points to agree (fewer of them project into the other image, widened by
/// max_transfer_error, than min_agreeing_share x min_testable) is returned
/// unjudged without reading its matches: on a 1,000-image street that is
/// nearly every pair. The model's images must keep the database's keypoints
/// as their points2D, as colmap's models do.
std::vector<PairAgreement> JudgePairsAgainstModel(
    const Database& database, const std::vector<ImagePair>& pairs,
    const Reconstruction& model, const ModelAgreementOptions& options);

}  // namespace hisfm
