#include "hisfm/verify/inlier_coverage.h"

#include <algorithm>
#include <cmath>

#include "hisfm/util/error.h"

namespace hisfm {

CoverageGrid::CoverageGrid(const Database& database, int grid_cells)
    : database_(database), grid_cells_(grid_cells) {
  ThrowUnless(grid_cells >= 1, "coverage grid needs at least one cell");
  for (const DatabaseCamera& c : database_.ReadCameras()) {
    cameras_[c.camera_id] = c;
  }
  for (const DatabaseImage& im : database_.ReadImages()) {
    camera_of_image_[im.image_id] = im.camera_id;
  }
}

const CoverageGrid::ImageCells& CoverageGrid::Cells(ImageId image_id) {
  auto it = cells_.find(image_id);
  if (it != cells_.end()) return it->second;
  ImageCells c;
  const Keypoints keypoints = database_.ReadKeypoints(image_id);
  uint64_t width = 0, height = 0;
  auto cam = camera_of_image_.find(image_id);
  if (cam != camera_of_image_.end()) {
    auto camera = cameras_.find(cam->second);
    if (camera != cameras_.end()) {
      width = camera->second.width;
      height = camera->second.height;
    }
  }
  if (width == 0 || height == 0) {
    // No usable camera size: take the keypoints' extent.
    for (int r = 0; r < keypoints.rows(); ++r) {
      width = std::max<uint64_t>(width, std::ceil(keypoints(r, 0)));
      height = std::max<uint64_t>(height, std::ceil(keypoints(r, 1)));
    }
    width = std::max<uint64_t>(width, 1);
    height = std::max<uint64_t>(height, 1);
  }
  const double cell = static_cast<double>(std::max(width, height)) /
                      grid_cells_;
  const int nx = static_cast<int>(std::ceil(width / cell));
  const int ny = static_cast<int>(std::ceil(height / cell));
  c.num_cells = nx * ny;
  std::vector<char> textured(static_cast<size_t>(nx) * ny, 0);
  c.cell_of_keypoint.resize(keypoints.rows());
  for (int r = 0; r < keypoints.rows(); ++r) {
    const int cx =
        std::clamp(static_cast<int>(keypoints(r, 0) / cell), 0, nx - 1);
    const int cy =
        std::clamp(static_cast<int>(keypoints(r, 1) / cell), 0, ny - 1);
    c.cell_of_keypoint[r] = cy * nx + cx;
    textured[c.cell_of_keypoint[r]] = 1;
  }
  c.num_textured_cells =
      static_cast<int>(std::count(textured.begin(), textured.end(), 1));
  return cells_.emplace(image_id, std::move(c)).first->second;
}

int CoverageGrid::CountCells(const ImageCells& c,
                             FeatureMatchSpan matches,
                             bool first, Scratch* scratch) {
  const size_t n = c.cell_of_keypoint.size();
  if (c.num_cells <= 128) {
    // Few cells (the default grid has at most 100): a bit per cell, in two
    // registers (a mask in memory would make each match wait for the last).
    const int* cell_of = c.cell_of_keypoint.data();
    uint64_t low = 0, high = 0;
    auto add = [&](Point2DIdx idx) {
      if (idx >= n) return;
      const uint32_t cell = static_cast<uint32_t>(cell_of[idx]);
      const uint64_t bit = uint64_t{1} << (cell & 63);
      const uint64_t is_high = uint64_t{0} - (cell >> 6);
      low |= bit & ~is_high;
      high |= bit & is_high;
    };
    if (first) {
      for (const FeatureMatch& m : matches) add(m.idx1);
    } else {
      for (const FeatureMatch& m : matches) add(m.idx2);
    }
    return __builtin_popcountll(low) + __builtin_popcountll(high);
  }
  // Distinct cells counted with a stamp per cell: no sort, no clearing.
  std::vector<uint32_t>& stamp = scratch->stamp;
  if (stamp.size() < static_cast<size_t>(c.num_cells)) {
    stamp.resize(c.num_cells, 0);
  }
  if (++scratch->current == 0) {
    std::fill(stamp.begin(), stamp.end(), 0);
    scratch->current = 1;
  }
  const uint32_t current = scratch->current;
  int count = 0;
  for (const FeatureMatch& m : matches) {
    const Point2DIdx idx = first ? m.idx1 : m.idx2;
    if (idx >= n) continue;
    uint32_t& s = stamp[c.cell_of_keypoint[idx]];
    if (s != current) {
      s = current;
      ++count;
    }
  }
  return count;
}

int CoverageGrid::CoveredCells(ImageId image_id,
                               FeatureMatchSpan matches,
                               bool first) {
  return CountCells(Cells(image_id), matches, first, &scratch_);
}

int CoverageGrid::CoveredCells(ImageId image_id,
                               FeatureMatchSpan matches,
                               bool first, Scratch* scratch) const {
  auto it = cells_.find(image_id);
  if (it == cells_.end()) {
    throw Error(StrCat("coverage grid: image ", image_id, " was not loaded"));
  }
  return CountCells(it->second, matches, first, scratch);
}

int CoverageGrid::TexturedCells(ImageId image_id) {
  return Cells(image_id).num_textured_cells;
}

}  // namespace hisfm
