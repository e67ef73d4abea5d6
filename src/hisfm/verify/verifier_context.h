// What the hierarchy offers a bridge verifier as context.
#pragma once

#include <string>
#include <unordered_map>

#include "hisfm/graph/communities.h"
#include "hisfm/graph/view_graph.h"
#include "hisfm/io/database.h"

namespace hisfm {

/// Context of a verification run. Pointers stay valid while the verifier is
/// used (during the hierarchy build).
struct VerifierContext {
  const Database* database = nullptr;
  const ViewGraph* graph = nullptr;
  const Communities* communities = nullptr;
  /// Folder of the photos (may be empty when only the database is used).
  std::string image_path;
  /// Image names by id.
  std::unordered_map<ImageId, std::string> image_names;
};

}  // namespace hisfm
