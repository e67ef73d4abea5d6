// Burstiness-weighted support of image pairs.
//
// A feature on repeated structure (a window of a facade of identical houses,
// a motif of a symmetric print) matches many images, the right copy and the
// wrong ones alike; a feature on unique content matches only the images that
// truly see it. Weighting each inlier by the inverse square root of the
// product of its two keypoints' match counts (the number of verified pairs
// in which each keypoint is an inlier) down-weights such "bursty" features,
// as Jegou, Douze, Schmid, "On the burstiness of visual elements", CVPR
// 2009, do for image retrieval (and tf-idf weighting, Sivic & Zisserman,
// ICCV 2003): a pair supported only by repeated structure has a small
// weight even with many inliers, and each image's true neighbours rank
// above its doppelgangers.
#pragma once

#include <unordered_map>
#include <vector>

#include "hisfm/graph/view_graph.h"
#include "hisfm/io/database.h"

namespace hisfm {

/// Per image, per keypoint: the number of pairs of `graph` in which the
/// keypoint is an inlier (saturating at 65535; one read of every pair's
/// inliers).
using KeypointDegrees = std::unordered_map<ImageId, std::vector<uint16_t>>;
KeypointDegrees ComputeKeypointDegrees(const Database& database,
                                       const ViewGraph& graph);

/// Per pair, the sum over its inliers of 1 / sqrt(n1 n2), n1 and n2 the
/// degrees of its two keypoints (one more read of every pair's inliers).
std::unordered_map<ImagePair, double, ImagePairHash> BurstinessWeights(
    const Database& database, const ViewGraph& graph,
    const KeypointDegrees& degrees);

/// The graph with each edge's weight replaced by round(scale * burstiness
/// weight), at least 1 (the same images and edges).
ViewGraph ReweightedGraph(
    const ViewGraph& graph,
    const std::unordered_map<ImagePair, double, ImagePairHash>& weights,
    double scale = 100.0);

}  // namespace hisfm
