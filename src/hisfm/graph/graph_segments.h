// Overlapping segments of a large view graph, each small enough for one
// incremental mapper run, whose models are merged through the images
// consecutive segments share.
//
// The images are put in a banded order (Cuthill and McKee, "Reducing the
// bandwidth of sparse symmetric matrices", ACM National Conference 1969;
// Boost.Graph's cuthill_mckee_ordering): a breadth-first order from a
// pseudo-peripheral image, in which an edge joins images near each other in
// the order. Windows of that order then hold most of their images' edges;
// on a street it is the order along the street. This is the divide step of
// divide-and-conquer SfM (e.g. Bhowmick et al., "Divide and Conquer:
// Efficient Large-Scale Structure from Motion Using Graph Partitioning",
// ACCV 2014; COLMAP's hierarchical_mapper), reduced to windows of one order
// so that consecutive segments overlap by construction.
#pragma once

#include <cstddef>
#include <utility>
#include <vector>

#include "hisfm/util/types.h"

namespace hisfm {

/// The fewest spans [begin, end) of `n` places, all of one length of at
/// most `span` places, spread evenly from the first place to the last, such
/// that consecutive spans share at least `overlap` places. n <= span, or
/// span = 0, gives the one span [0, n) (none for n = 0). Throws hisfm::Error
/// unless 0 < overlap < span (when n > span > 0).
std::vector<std::pair<size_t, size_t>> OverlappingSpans(size_t n, size_t span,
                                                        size_t overlap);

/// `images` in a banded (Cuthill-McKee) order of the graph of `edges`:
/// breadth first from a pseudo-peripheral image of each connected
/// component, neighbours by increasing degree; components follow one
/// another, images without an edge come last, in their given order. Edges
/// with an image outside `images` are ignored. `images` must be distinct.
std::vector<ImageId> BandedOrder(const std::vector<ImageId>& images,
                                 const std::vector<ImagePair>& edges);

/// `images` cut into overlapping segments of at most `segment_images`
/// images: OverlappingSpans of their BandedOrder (consecutive segments share
/// at least `overlap` images). Each segment lists its images in that order.
/// At most segment_images images, or segment_images = 0, give one segment
/// of every image; no images give no segment. Throws hisfm::Error as
/// OverlappingSpans does. On a graph that branches (streets that cross) a
/// window holds pieces of several branches, which may meet only outside it:
/// its run then gives several models, merged with the other windows' through
/// the images they share.
std::vector<std::vector<ImageId>> GraphSegments(
    const std::vector<ImageId>& images, const std::vector<ImagePair>& edges,
    size_t segment_images, size_t overlap);

}  // namespace hisfm
