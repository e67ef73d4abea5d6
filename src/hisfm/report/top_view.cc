#include "hisfm/report/top_view.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

namespace hisfm {

namespace {

// Any unit vector perpendicular to the unit vector `v`.
Eigen::Vector3d AnyPerpendicular(const Eigen::Vector3d& v) {
  const Eigen::Vector3d other = std::abs(v.x()) < 0.9
                                    ? Eigen::Vector3d::UnitX()
                                    : Eigen::Vector3d::UnitY();
  return v.cross(other).normalized();
}

}  // namespace

TopViewFrame ComputeTopViewFrame(const Reconstruction& model) {
  TopViewFrame frame;
  if (model.images.empty()) return frame;
  std::vector<Eigen::Vector3d> centers;
  Eigen::Vector3d up_sum = Eigen::Vector3d::Zero();
  for (const auto& [id, image] : model.images) {
    centers.push_back(image.ProjectionCenter());
    // The camera's -y axis in world coordinates.
    up_sum +=
        image.cam_from_world.rotation.inverse() * Eigen::Vector3d(0, -1, 0);
  }
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const Eigen::Vector3d& c : centers) mean += c;
  mean /= static_cast<double>(centers.size());
  frame.origin = mean;
  // 1 if all cameras agree on "up", near 0 if they disagree.
  const double up_agreement = up_sum.norm() / centers.size();
  const Eigen::Vector3d up =
      up_sum.norm() > 1e-9 ? Eigen::Vector3d(up_sum.normalized())
                           : Eigen::Vector3d::UnitZ();

  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const Eigen::Vector3d& c : centers) {
    cov += (c - mean) * (c - mean).transpose();
  }
  Eigen::Vector3d x, y;
  if (up_agreement >= kMinUpAgreement) {
    // Look down along the common up direction; x along the main direction
    // of the centres within the horizontal plane.
    const Eigen::Matrix3d horizontal =
        Eigen::Matrix3d::Identity() - up * up.transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(
        horizontal * cov * horizontal);
    x = horizontal * solver.eigenvectors().col(2);
    if (solver.eigenvalues()(2) <= 0 || x.norm() < 1e-9) {
      x = AnyPerpendicular(up);
    }
    x.normalize();
    y = up.cross(x);
    frame.along_up = true;
  } else {
    // Cameras disagree on "up": the plane of the two main directions of
    // the centres (principal component analysis).
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver(cov);
    const Eigen::Vector3d values = solver.eigenvalues();  // Ascending.
    const Eigen::Matrix3d vectors = solver.eigenvectors();
    if (centers.size() >= 3 && values(2) > 0 && values(1) > 1e-4 * values(2)) {
      x = vectors.col(2);
      y = vectors.col(1);
    } else {
      x = values(2) > 0 ? Eigen::Vector3d(vectors.col(2)) : AnyPerpendicular(up);
      y = up.cross(x);
      if (y.norm() < 1e-9) y = AnyPerpendicular(x);
    }
    if (x.cross(y).dot(up) < 0) y = -y;
  }
  frame.axis_x = x.normalized();
  frame.axis_y = (y - y.dot(frame.axis_x) * frame.axis_x).normalized();
  return frame;
}

std::map<uint32_t, Eigen::Vector2d> CommunityCircleLayout(
    const std::map<uint32_t, int>& community_of) {
  std::map<int, std::vector<uint32_t>> members;
  for (const auto& [image, community] : community_of) {
    members[community].push_back(image);
  }
  std::map<uint32_t, Eigen::Vector2d> out;
  if (members.empty()) return out;
  size_t max_size = 1;
  for (const auto& [c, images] : members) {
    max_size = std::max(max_size, images.size());
  }
  const size_t num = members.size();
  const double kPi = 3.14159265358979323846;
  // Community centres on a circle of radius `big`; each community gets a
  // disc of radius `room`, 90% of half the distance between neighbouring
  // centres, and big + room = 1.
  const double half_chord = num == 1 ? 1.0 : std::sin(kPi / num);
  const double big = num == 1 ? 0.0 : 1.0 / (1.0 + 0.9 * half_chord);
  const double room = num == 1 ? 0.9 : 0.9 * big * half_chord;
  size_t k = 0;
  for (const auto& [c, images] : members) {
    const double a = 2 * kPi * k / num - kPi / 2;
    const Eigen::Vector2d center(big * std::cos(a), big * std::sin(a));
    const double r =
        room * std::sqrt(static_cast<double>(images.size()) / max_size);
    for (size_t i = 0; i < images.size(); ++i) {
      if (images.size() == 1) {
        out[images[i]] = center;
        continue;
      }
      const double b = 2 * kPi * i / images.size() + a;
      out[images[i]] = center + r * Eigen::Vector2d(std::cos(b), std::sin(b));
    }
    ++k;
  }
  return out;
}

bool AlignReferenceToModel(const Reconstruction& model,
                           const Reconstruction& reference,
                           Sim3d* model_from_reference, size_t* num_common) {
  std::vector<Eigen::Vector3d> source, target;
  for (const auto& [id, image] : reference.images) {
    const Image* other = model.FindImageWithName(image.name);
    if (other == nullptr) continue;
    source.push_back(image.ProjectionCenter());
    target.push_back(other->ProjectionCenter());
  }
  if (num_common) *num_common = source.size();
  if (source.size() < 3) return false;
  const SimilarityAlignment alignment =
      AlignSimilarityRobust(source, target, SimilarityAlignmentOptions());
  if (!alignment.success) return false;
  *model_from_reference = alignment.target_from_source;
  return true;
}

}  // namespace hisfm
