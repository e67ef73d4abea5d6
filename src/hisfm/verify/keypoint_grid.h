// A uniform grid over an image's keypoints for fixed-radius queries.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

namespace hisfm {

/// Buckets an image's keypoints (pixel coordinates) into square cells whose
/// side is the query radius, so that "is there a keypoint within r pixels
/// of u" looks at 3x3 cells.
class KeypointGrid {
 public:
  KeypointGrid() = default;
  /// `radius` is the query radius in pixels (> 0); keypoints outside
  /// [0, width) x [0, height) are clamped to the border cells.
  KeypointGrid(const std::vector<Eigen::Vector2d>& keypoints, double width,
               double height, double radius);

  /// True if some keypoint lies within the radius of `u`.
  bool AnyWithin(const Eigen::Vector2d& u) const;
  /// Number of keypoints.
  size_t size() const { return points_.size(); }

 private:
  int CellX(double x) const;
  int CellY(double y) const;

  double radius_ = 1.0;
  int cols_ = 0;
  int rows_ = 0;
  // Keypoints sorted by cell; cell c holds points_[start_[c], start_[c+1]).
  std::vector<Eigen::Vector2d> points_;
  std::vector<uint32_t> start_;
};

}  // namespace hisfm
