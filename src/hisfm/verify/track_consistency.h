// Distinctive keypoints: keypoints whose feature track is consistent.
//
// The inlier matches of all verified pairs, joined transitively, form
// feature tracks. A track that holds two different keypoints of one image is
// inconsistent: somewhere along it a feature was matched to a copy of
// itself. Photo Tourism (Snavely, Seitz, Szeliski, "Photo Tourism: Exploring
// Photo Collections in 3D", SIGGRAPH 2006, Sec. 4.1) drops such tracks;
// Wilson & Snavely ("Network Principles for SfM: Disambiguating Repeated
// Structures with Local Context", ICCV 2013) and Heinly et al. ("Correcting
// for Duplicate Scene Structure in Sparse 3D Reconstruction", ECCV 2014)
// build on the same observation: features of repeated structure (windows of
// a facade, the repeated print of an object seen twice in one photo) end up
// in inconsistent tracks, while unique content (the ground, a shop sign)
// keeps consistent ones. We call a matched keypoint *distinctive* if its
// track is consistent.
//
// A doppelganger pair of such a scene matches only repeated structure, so
// almost none of its inliers are distinctive, whereas a true pair of the same
// images matches their unique content as well: its fraction of distinctive
// inliers is about the fraction of distinctive keypoints among everything
// its images match elsewhere. The ratio of the two is scale- and
// overlap-free and needs no threshold on the scene.
//
// Limits: repetition that is never seen twice in one image (a 2-fold
// symmetric object, whose two sides no photo shows at once) leaves its
// tracks consistent and is not detected here (the coverage cue of
// context_disambiguator.h handles it). Random wrong inliers that join two
// tracks of unique content can mark a few distinctive keypoints as
// repeated; the ratio compares like with like, so this lowers both sides.
#pragma once

#include <cstdint>
#include <functional>
#include <unordered_map>
#include <vector>

#include "hisfm/graph/view_graph.h"
#include "hisfm/io/database.h"
#include "hisfm/verify/keypoint_multisets.h"

namespace hisfm {

/// How much distinctive content a pair's inliers hold.
struct DistinctiveSupport {
  uint32_t num_inliers = 0;
  /// Inliers whose keypoints are distinctive.
  uint32_t num_distinctive = 0;
  /// Smaller distinctive fraction of the pair's two images.
  double image_fraction = 0;
  /// num_inliers * image_fraction: what a true pair would hold.
  double expected = 0;
  /// min(1, num_distinctive / expected); 1 if nothing is expected.
  double ratio = 1;
  /// P(X <= num_distinctive) for X ~ Poisson(expected): how surprising the
  /// shortfall is for a true pair (1 if nothing is expected).
  double p_value = 1;

  /// True if the pair holds fewer than `min_ratio` of the expected
  /// distinctive inliers and the shortfall is significant at `alpha`.
  bool Deficient(double min_ratio, double alpha) const {
    return ratio < min_ratio && p_value < alpha;
  }
};

/// Track consistency of the keypoints of every image in a view graph.
class TrackConsistency {
  enum : uint8_t { kUnmatched = 0, kDistinctive = 1, kRepeated = 2 };

 public:
  TrackConsistency() = default;
  /// Joins the inlier matches of every edge of `graph` (read from
  /// `database`) into tracks and marks the keypoints of inconsistent tracks.
  /// Costs one read of every edge's inliers (in pair-id order, in one read
  /// transaction) and near-linear time in the number of inlier matches.
  /// For callers that need more of the inliers, `on_read` and `on_join`, if
  /// set, are also called with every edge's inliers (oriented as stored,
  /// in pair-id order) during that read: `on_read` on the reading thread
  /// (Database::ForEachInlierMatches' on_read), concurrently with the
  /// joining, and `on_join` on this thread once the edge is joined. Work
  /// split between the two uses both cores. Neither may use this
  /// TrackConsistency, and the two must not share unsynchronized state.
  TrackConsistency(
      const Database& database, const ViewGraph& graph,
      const std::function<void(const ImagePair&, FeatureMatchSpan)>& on_read =
          nullptr,
      const std::function<void(const ImagePair&, FeatureMatchSpan)>& on_join =
          nullptr);

  /// True if keypoint `idx` of the image has an inlier match in some edge.
  bool IsMatched(ImageId image_id, uint32_t idx) const;
  /// True if the keypoint is matched and its track is consistent.
  bool IsDistinctive(ImageId image_id, uint32_t idx) const;

  /// The keypoints of one image, for loops over many of them (one image
  /// lookup instead of one per keypoint).
  class ImageKeypoints {
   public:
    /// Same as TrackConsistency::IsDistinctive for this image.
    bool IsDistinctive(uint32_t idx) const {
      return idx < num_keypoints_ && states_[idx] == kDistinctive;
    }

   private:
    friend class TrackConsistency;
    const uint8_t* states_ = nullptr;
    size_t num_keypoints_ = 0;
  };
  /// The keypoints of `image_id` (none if the image is unknown); valid while
  /// this TrackConsistency lives.
  ImageKeypoints KeypointsOf(ImageId image_id) const;

  /// Fraction of an image's matched keypoints that are distinctive (0 for an
  /// image without matched keypoints or unknown to the graph).
  double DistinctiveFraction(ImageId image_id) const;
  /// Number of an image's matched keypoints.
  size_t NumMatched(ImageId image_id) const;

  /// Over all matched keypoints: fraction in inconsistent tracks.
  double InconsistentFraction() const;

  /// The distinctive support of a pair's inlier matches, oriented like
  /// `pair` (idx1 indexes pair.image_id1).
  DistinctiveSupport Support(const ImagePair& pair,
                             FeatureMatchSpan inliers) const;
  /// Same for a pair with `num_inliers` inliers whose keypoints in
  /// pair.image_id1 are multiset `k` of `keypoints` (the same count
  /// without the inliers themselves).
  DistinctiveSupport Support(const ImagePair& pair, uint32_t num_inliers,
                             const KeypointMultisets& keypoints,
                             size_t k) const;

 private:
  struct ImageState {
    size_t offset = 0;
    size_t num_keypoints = 0;
    size_t num_matched = 0;
    size_t num_distinctive = 0;
    // The image's words in distinctive_bits_.
    size_t word_offset = 0;
  };
  uint8_t State(ImageId image_id, uint32_t idx) const;
  // The support of `num_distinctive` distinctive inliers out of
  // `num_inliers`.
  DistinctiveSupport SupportFromCount(const ImagePair& pair,
                                      uint32_t num_inliers,
                                      uint32_t num_distinctive) const;

  std::unordered_map<ImageId, ImageState> images_;
  std::vector<uint8_t> state_;
  // Bit k of an image's words: its keypoint k is distinctive.
  std::vector<uint64_t> distinctive_bits_;
  size_t num_matched_ = 0;
  size_t num_repeated_ = 0;
};

}  // namespace hisfm
