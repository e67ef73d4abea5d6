#include "hisfm/verify/keypoint_grid.h"

#include <algorithm>
#include <cmath>

namespace hisfm {

KeypointGrid::KeypointGrid(const std::vector<Eigen::Vector2d>& keypoints,
                           double width, double height, double radius)
    : radius_(radius) {
  cols_ = std::max(1, static_cast<int>(std::ceil(width / radius)));
  rows_ = std::max(1, static_cast<int>(std::ceil(height / radius)));
  const size_t num_cells = static_cast<size_t>(cols_) * rows_;
  std::vector<uint32_t> count(num_cells + 1, 0);
  std::vector<uint32_t> cell_of(keypoints.size());
  for (size_t k = 0; k < keypoints.size(); ++k) {
    cell_of[k] = static_cast<uint32_t>(CellY(keypoints[k].y()) * cols_ +
                                       CellX(keypoints[k].x()));
    ++count[cell_of[k] + 1];
  }
  for (size_t c = 0; c < num_cells; ++c) count[c + 1] += count[c];
  start_ = count;
  points_.resize(keypoints.size());
  for (size_t k = 0; k < keypoints.size(); ++k) {
    points_[count[cell_of[k]]++] = keypoints[k];
  }
}

int KeypointGrid::CellX(double x) const {
  return std::clamp(static_cast<int>(std::floor(x / radius_)), 0, cols_ - 1);
}

int KeypointGrid::CellY(double y) const {
  return std::clamp(static_cast<int>(std::floor(y / radius_)), 0, rows_ - 1);
}

bool KeypointGrid::AnyWithin(const Eigen::Vector2d& u) const {
  if (points_.empty() || !u.allFinite()) return false;
  const int cx = CellX(u.x());
  const int cy = CellY(u.y());
  const double r2 = radius_ * radius_;
  for (int y = std::max(0, cy - 1); y <= std::min(rows_ - 1, cy + 1); ++y) {
    for (int x = std::max(0, cx - 1); x <= std::min(cols_ - 1, cx + 1); ++x) {
      const size_t c = static_cast<size_t>(y) * cols_ + x;
      for (uint32_t k = start_[c]; k < start_[c + 1]; ++k) {
        if ((points_[k] - u).squaredNorm() <= r2) return true;
      }
    }
  }
  return false;
}

}  // namespace hisfm
