// Checks of a COLMAP database before colmap runs on it: what colmap would
// crash on is reported as one line instead.
#pragma once

#include <vector>

#include "hisfm/graph/view_graph.h"
#include "hisfm/io/database.h"

namespace hisfm {

/// Throws hisfm::Error (one line) if an image of `images` refers to a camera
/// that is not in the database, or an image with verified pairs in `graph`
/// has no keypoints.
void CheckImagesUsable(const Database& database,
                       const std::vector<DatabaseImage>& images,
                       const ViewGraph& graph);

}  // namespace hisfm
