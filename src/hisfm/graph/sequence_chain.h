// The capture sequence as a prior: when image names order the photos as they
// were taken (a video, a walk along a street, a circle around an object),
// consecutive photos overlap for real, where pairs far apart in the sequence
// are where doppelgangers live. The chain of consecutive verified pairs is
// then a doppelganger-free backbone (loop closures are accepted only when
// they agree with it, recon/sequence_pass.h).
//
// This is the reasoning of sequential SfM and visual SLAM: odometry along the
// sequence, loop closures verified against it (e.g. Cummins and Newman,
// "FAB-MAP", IJRR 2008; Mur-Artal et al., "ORB-SLAM", T-RO 2015). COLMAP's
// sequential matcher sorts images by name in the same way. Whether the names
// carry the order is decided from the matches themselves: consecutive names
// must be matched much more strongly than names in a shuffled order (a
// permutation test), so an unordered collection keeps today's pipeline.
#pragma once

#include <string>
#include <unordered_map>
#include <vector>

#include "hisfm/graph/view_graph.h"
#include "hisfm/util/types.h"

namespace hisfm {

struct SequenceOptions {
  /// "auto": use the name order when the matches show it is the capture
  /// order (min_consecutive_share and min_z_score); "on": always; "off":
  /// never.
  std::string mode = "auto";
  /// auto: at least this share of consecutive names must be verified pairs.
  double min_consecutive_share = 0.9;
  /// auto: the inliers summed over consecutive names must lie this many
  /// standard deviations above their mean over shuffled name orders. A
  /// shuffled collection scores about 0 (the test's own null); the
  /// sequences of ../shared/data score 6 to 27, the 40-image synthetic
  /// families 13 to 18 (docs/decisions.md, twenty-first session).
  double min_z_score = 5.0;
  /// Shuffled orders of the permutation test (fixed seed).
  int num_permutations = 200;
  /// A consecutive pair is a link of the chain unless its inliers fall below
  /// this share of the median over the consecutive pairs within
  /// break_window places on either side (where a capture jumps, e.g. from
  /// one street to the next, the pair across the jump is weak or wrong).
  /// Chosen on the tuning half (odd seeds) of the 40- to 1,000-image
  /// families, by the outcome of the chain: consecutive pairs that glue the
  /// chain wrongly lie at 0.05 to 0.37 of their neighbours' median
  /// (crossing_streets_1000_s3: 0.37; crossing_streets_40_s3: 0.31), the
  /// weakest one the chain needs at 0.45 (block_loop_150_s3)
  /// (docs/decisions.md, twenty-first session).
  double break_ratio = 0.4;
  /// Consecutive pairs on each side that the break test compares with.
  int break_window = 5;

  /// Throws hisfm::Error if an option is out of range.
  void Check() const;
};

/// What FindSequenceChain found.
struct SequenceChain {
  /// True when the prior applies (mode "on", or "auto" and both tests pass;
  /// never with fewer than 2 images).
  bool applies = false;
  /// Images in name order (every image of the graph).
  std::vector<ImageId> order;
  /// Share of consecutive names that are verified pairs.
  double consecutive_share = 0.0;
  /// The permutation test's z-score (0 with fewer than 3 images).
  double z_score = 0.0;
  /// The chain's links: consecutive verified pairs not broken off, sorted.
  std::vector<ImagePair> links;
  /// Consecutive pairs left out: unverified, or weak against their
  /// neighbours (break_ratio).
  size_t num_breaks = 0;
};

/// Orders the graph's images by name (byte-wise, as COLMAP's sequential
/// matcher), tests whether that order is the capture order, and finds the
/// chain's links. `names` must name every image of the graph.
SequenceChain FindSequenceChain(
    const ViewGraph& graph,
    const std::unordered_map<ImageId, std::string>& names,
    const SequenceOptions& options);

/// The pairs of `pairs` whose two images lie at most `window` places apart
/// in the chain's order with a link between every two consecutive images
/// from one to the other: pairs inside an unbroken stretch of the chain,
/// which the capture order vouches for as it does for the links. Pairs with
/// an image outside the order are left out; the order of `pairs` is kept.
std::vector<ImagePair> NearChainPairs(const SequenceChain& chain,
                                      const std::vector<ImagePair>& pairs,
                                      int window);

/// The chain's links cut into overlapping segments of the name order
/// (OverlappingSpans, graph_segments.h: the fewest segments of at most
/// segment_images places, all of one length and spread evenly, such that
/// consecutive ones share at least `overlap` places, so that their models
/// can be merged through those images); each holds the links whose two images
/// lie in its span (in the chain's sorted order). A chain of at most
/// segment_images images, or segment_images = 0, gives one segment with every
/// link. Segments without a link are left out. Throws hisfm::Error unless 0 <
/// overlap < segment_images (when segment_images > 0).
std::vector<std::vector<ImagePair>> ChainSegments(const SequenceChain& chain,
                                                  size_t segment_images,
                                                  size_t overlap);

}  // namespace hisfm
