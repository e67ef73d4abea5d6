// Image coverage of a set of keypoints on a square occupancy grid.
//
// Counting the grid cells that hold a pair's inlier keypoints measures how
// much of an image the pair explains, independently of how densely the
// matcher samples it (used by context_disambiguator.h and pair_filter.h).
#pragma once

#include <cstdint>
#include <unordered_map>
#include <vector>

#include "hisfm/io/database.h"

namespace hisfm {

/// Cell of every keypoint of the database's images, cached per image.
class CoverageGrid {
 public:
  /// `grid_cells` cells along the longer image side (square cells). The
  /// database must outlive the grid.
  CoverageGrid(const Database& database, int grid_cells);

  /// Number of distinct cells holding the keypoints of `image_id` that the
  /// matches index (idx1 if `first`, else idx2). Out-of-range indices are
  /// ignored.
  int CoveredCells(ImageId image_id, FeatureMatchSpan matches, bool first);
  /// Cells of an image holding any keypoint.
  int TexturedCells(ImageId image_id);

  /// Scratch memory of CoveredCells; one per thread.
  struct Scratch {
    std::vector<uint32_t> stamp;
    uint32_t current = 0;
  };
  /// Loads (and caches) an image's keypoint cells, so that the const
  /// CoveredCells below can be used on it.
  void Load(ImageId image_id) { Cells(image_id); }
  /// As CoveredCells above, for an image already loaded (throws otherwise);
  /// safe to call from several threads at once, each with its own scratch.
  int CoveredCells(ImageId image_id, FeatureMatchSpan matches, bool first,
                   Scratch* scratch) const;

 private:
  struct ImageCells {
    std::vector<int> cell_of_keypoint;
    int num_cells = 0;
    int num_textured_cells = 0;
  };
  const ImageCells& Cells(ImageId image_id);

  const Database& database_;
  int grid_cells_;
  std::unordered_map<CameraId, DatabaseCamera> cameras_;
  std::unordered_map<ImageId, CameraId> camera_of_image_;
  std::unordered_map<ImageId, ImageCells> cells_;
  static int CountCells(const ImageCells& cells,
                        FeatureMatchSpan matches, bool first,
                        Scratch* scratch);
  // Scratch of the non-const CoveredCells.
  Scratch scratch_;
};

}  // namespace hisfm
