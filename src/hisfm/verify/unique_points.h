// Unique and confusing 3D points of a reconstruction, after the confusing
// tracks of Yan, Kim, Lin, Chen, Wang and Fang ("Distinguishing the
// Indistinguishable: Exploring Structural Ambiguities via Geodesic
// Context", CVPR 2017). Each inlier match of a verified pair inside the
// model ties the points its two keypoints observe: to itself (the same
// point, or one within a share of its depth: a track the mapper split) or
// to a point elsewhere. A point tied elsewhere often enough is confusing:
// the model holds several copies of a repeated structure and the matcher
// could not tell them apart. The others (clutter, a sign, a corner seen
// once) are unique; the odd outlier match that ties them elsewhere does not
// make them confusing.
//
// A unique point of one model that another model's photo should see, under
// a proposed join of the two, but does not match is the conflict of
// Heinly, Dunn and Frahm ("Correcting for Duplicate Scene Structure in
// Sparse 3D Reconstruction", ECCV 2014) (recon/conflict_join.h).
#pragma once

#include <unordered_set>
#include <vector>

#include "hisfm/io/database.h"
#include "hisfm/io/model.h"
#include "hisfm/util/types.h"

namespace hisfm {

struct UniquePointOptions {
  /// Two points of a match are the same when they lie within this share of
  /// the first's depth in its image (the merge's tolerance,
  /// recon/model_merge.h).
  double max_relative_distance = 0.1;
  /// A point is confusing when its matches tie it elsewhere more than this
  /// many times for each tie to itself. On the two 500-image pieces of
  /// crossing_streets_1000_s3 (tuning), 0.3 and 1.0 both left about 4,000 of
  /// 31,291 points unique and the same joins (docs/decisions.md,
  /// twenty-second session).
  double max_far_ties_per_near_tie = 0.5;

  /// Throws hisfm::Error if an option is out of range.
  void Check() const;
};

/// The confusing points of `model`: those whose inlier matches in `pairs`
/// (the pairs with both images registered in `model`; the others are not
/// read) tie them to a far point more than max_far_ties_per_near_tie times
/// per tie to themselves. Matches with a keypoint that observes no point are
/// ignored. The model's images must keep the database's keypoints as their
/// points2D, as colmap's models do; a match past them throws hisfm::Error.
std::unordered_set<Point3DId> FindConfusingPoints(
    const Database& database, const std::vector<ImagePair>& pairs,
    const Reconstruction& model, const UniquePointOptions& options = {});

}  // namespace hisfm
