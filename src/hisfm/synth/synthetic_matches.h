// Feature matches between synthetic images, and their geometric verification
// from the ground truth ("direct" two-view geometries).
//
// Matching imitates SIFT with repeated structure. A feature of image 1 can
// match the features of image 2 with the same appearance id whose viewing rays
// (in the local surface frame) differ by less than max_view_angle and whose
// distances differ by less than max_scale_ratio; among several such
// candidates (a repeated appearance visible several times) the one with the
// most similar viewing ray wins, and matches must be mutual best candidates
// (cross check). A match between two copies of repeated content is a
// doppelganger match: it is consistent with the epipolar geometry of image 1
// and image 2 moved by the symmetry relating the copies. A few random wrong
// matches are added (SynthOptions::outlier_ratio).
//
// Direct verification imitates RANSAC: each epipolar geometry supported by
// the matches (the true one and one per symmetry element relating matched
// copies) is scored by the matches within max_error pixels of Sampson error;
// the geometry with the most inliers is kept (the true one on ties). A pair
// is verified if it keeps at least min_num_inliers inliers and
// min_inlier_ratio of its matches; it is written as a CALIBRATED geometry
// with E, F and the relative pose of the kept hypothesis.
//
// Family scenes (SceneLayout::family) differ in three ways:
//  - candidate pairs are all pairs of images that see a common appearance
//    (an exhaustive matcher's pairs that can match at all);
//  - the descriptor proxy carries noise (SynthFamilyOptions::
//    descriptor_noise), so among copies seen under similar angles the match
//    is partly random;
//  - verification imitates COLMAP's calibrated two-view estimation, which
//    runs RANSAC for both an essential and a fundamental matrix and keeps
//    the essential one unless the fundamental one has more than 1 / 0.95
//    times its inliers. Essential candidates are the true geometry and every
//    supported symmetry element, as above. Fundamental candidates are
//    least-squares fits (normalised eight-point) to the union of two of the
//    three largest groups of matches (a group: one label, and repeated or
//    unique points), and to the union of those three: where several
//    geometries share epipolar lines (the copies of a planar facade seen
//    along a street) such a fit explains them all, as RANSAC's best model
//    does. The inliers are then every match within max_error (Sampson) of
//    the kept matrix, whatever its label, so true pairs keep wrong matches
//    that lie on their epipolar lines. The geometry is written as
//    CALIBRATED (E and its F) or UNCALIBRATED (the fitted F, and E of the
//    best essential candidate), with qvec and tvec left zero as COLMAP's
//    matchers leave them. Homographies fitted to each of the three largest
//    groups (transfer error within max_error) decide, as in COLMAP, whether
//    the pair is PLANAR_OR_PANORAMIC: a homography with more than 0.8 times
//    the kept matrix's inliers (its inliers replace those when more).
#pragma once

#include <functional>
#include <limits>
#include <vector>

#include "hisfm/io/database.h"
#include "hisfm/synth/synthetic_scene.h"

namespace hisfm {

/// Label of a random wrong match.
constexpr int kOutlierMatchLabel = std::numeric_limits<int>::min();

/// Putative matches of an image pair.
struct SynthPairMatches {
  /// The pair (image ids); matches index pair.image_id1's keypoints first.
  ImagePair pair;
  std::vector<FeatureMatch> matches;
  /// Per match: the symmetry element k relating the two observed points
  /// (point2 = g_k(point1); 0 = the same point, a true match), or
  /// kOutlierMatchLabel for a random wrong match.
  std::vector<int> labels;

  /// Number of matches with label 0 (true matches).
  size_t NumTrueMatches() const;
  /// Number of doppelganger matches (label neither 0 nor outlier).
  size_t NumDoppelgangerMatches() const;
};

/// Outcome of the direct verification of a pair.
struct SynthVerification {
  /// At least min_num_inliers inliers and min_inlier_ratio of the matches.
  bool verified = false;
  /// Symmetry element of the kept epipolar geometry (0 = the true one);
  /// family scenes: of the best essential candidate, also when an
  /// UNCALIBRATED fundamental matrix was kept.
  int hypothesis = 0;
  /// Inliers that are true matches, doppelganger matches (two copies of
  /// repeated content) and random wrong matches.
  size_t num_true_inliers = 0;
  size_t num_doppelganger_inliers = 0;
  size_t num_random_inliers = 0;
  /// The geometry as written to two_view_geometries (inlier matches, config
  /// CALIBRATED, E, F, cam2_from_cam1 with a unit translation).
  TwoViewGeometry geometry;

  /// A verified pair whose kept geometry is a doppelganger one.
  bool IsDoppelganger() const { return verified && hypothesis != 0; }
  /// A verified pair most of whose inliers are doppelganger matches (how
  /// the family scenes count doppelganger pairs: along a straight street
  /// the true geometry may explain the wrong matches of distant images).
  bool MostlyDoppelganger() const {
    return verified && num_doppelganger_inliers > num_true_inliers;
  }
};

/// A matched pair with its verification.
struct SynthPair {
  SynthPairMatches matches;
  SynthVerification verification;
};

/// Image pairs that may share matches: pairs (i, j) such that for some
/// symmetry element k the centre of i and g_k^-1 of the centre of j are
/// closer than the layout's pair_radius; family scenes: pairs whose images
/// see a common appearance. Sorted, image ids.
std::vector<ImagePair> FindSynthCandidatePairs(const SyntheticScene& scene);

/// The putative matches of two images (image ids, in any order; the result
/// is oriented with pair.image_id1 < pair.image_id2). Deterministic.
SynthPairMatches MatchSynthImages(const SyntheticScene& scene, ImageId id1,
                                  ImageId id2);

/// The relative pose cam2_from_cam1 under symmetry hypothesis k: the pose
/// that explains matches from points X in image 1 to g_k(X) in image 2
/// (k = 0: the true relative pose).
Rigid3d SynthHypothesisPose(const SyntheticScene& scene, ImageId id1,
                            ImageId id2, int k);

/// Direct verification of a pair's matches (see the file comment).
SynthVerification VerifySynthMatches(const SyntheticScene& scene,
                                     const SynthPairMatches& matches);

/// Matches and verifies every candidate pair in parallel and calls `fn` on
/// the calling thread for each pair with at least one match, in increasing
/// pair order. With `verify` false, verification is skipped (left default).
void ForEachSynthPair(const SyntheticScene& scene, bool verify,
                      const std::function<void(const SynthPair&)>& fn);

}  // namespace hisfm
