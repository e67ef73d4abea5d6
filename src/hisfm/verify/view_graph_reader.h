// The view graph of a COLMAP database: the graph layer takes plain images and
// edges, this reads them from the database.
#pragma once

#include <cstdint>

#include "hisfm/graph/view_graph.h"
#include "hisfm/io/database.h"

namespace hisfm {

/// The view graph of every image of `database` and every verified pair with
/// at least `min_num_matches` inliers (weight: its number of inliers).
ViewGraph ReadViewGraph(const Database& database, uint32_t min_num_matches);

}  // namespace hisfm
