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

int CoverageGrid::CoveredCells(ImageId image_id,
                               const std::vector<FeatureMatch>& matches,
                               bool first) {
  const ImageCells& c = Cells(image_id);
  std::vector<int> cells;
  cells.reserve(matches.size());
  for (const FeatureMatch& m : matches) {
    const Point2DIdx idx = first ? m.idx1 : m.idx2;
    if (idx < c.cell_of_keypoint.size()) {
      cells.push_back(c.cell_of_keypoint[idx]);
    }
  }
  std::sort(cells.begin(), cells.end());
  return static_cast<int>(std::unique(cells.begin(), cells.end()) -
                          cells.begin());
}

int CoverageGrid::TexturedCells(ImageId image_id) {
  return Cells(image_id).num_textured_cells;
}

}  // namespace hisfm
