// The exhaustive baseline the HiSfM paper compares against (Sec. IV, the
// Doppelgangers++ pipeline of Xiangli et al. 2025): score every verified
// pair with the verifier, drop the pairs it rejects, and hand the filtered
// database to vanilla `colmap mapper`. It shows what selective, lazy
// verification of bridges saves.
#pragma once

#include <nlohmann/json.hpp>
#include <string>

#include "hisfm/graph/communities.h"
#include "hisfm/verify/verifier_factory.h"

namespace hisfm {

struct ExhaustiveFilterOptions {
  /// Verified pairs with fewer inliers are dropped without scoring.
  int min_num_matches = 15;
  /// Pairs scoring below this are dropped.
  double verify_threshold = 0.5;
  /// Communities offered to the verifier as context.
  CommunityOptions communities;
  VerifierOptions verifier;
  /// Pairs per verifier call.
  int batch_size = 256;

  void Check() const;
};

/// Scores every verified pair of `database_path` and writes a copy to
/// `output_database_path` (cameras, images, keypoints, descriptors, and the
/// kept pairs' matches and two-view geometries). Returns counts and times.
nlohmann::json FilterPairsExhaustively(const std::string& database_path,
                                       const std::string& image_path,
                                       const std::string& output_database_path,
                                       const ExhaustiveFilterOptions& options);

}  // namespace hisfm
