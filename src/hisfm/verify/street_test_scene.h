// Test-only: a small street of identical houses written as a COLMAP
// database, for the tests of track_consistency, three_view_consistency,
// pair_filter and context_disambiguator (header-only so that no library
// carries it).
//
// Facades in the plane y = 8 repeat a random pattern every 4 m (or are all
// unique); the ground (z = 0) and a few facade details are unique. Cameras
// stand every 0.8 m along x at y = 0, 1.6 m high, looking along +y. A feature
// matches the same-looking feature of the other photo that appears at the
// most similar place in it (a proxy for SIFT's viewpoint tolerance), so
// photos a few houses apart match the facades falsely. Each pair keeps the
// matches of its most supported shift (0 = true) as the geometry, plus every
// other match within 4 px of its epipolar lines, as RANSAC would: photos
// about one house apart thus keep their true ground matches next to false
// facade matches ("mixed" pairs).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>
#include <map>
#include <random>
#include <string>
#include <vector>

#include "hisfm/graph/view_graph.h"
#include "hisfm/io/database.h"
#include "hisfm/io/database_writer.h"
#include "hisfm/util/test_util.h"
#include "hisfm/verify/view_graph_reader.h"

namespace hisfm {
namespace street_test {

struct Options {
  int num_images = 16;
  /// False: every house unique (the control scene).
  bool repeated = true;
  uint32_t seed = 1;
};

/// What the tests need to know about the written scene.
struct Scene {
  /// Per image (index = image id - 1): scene point of each keypoint, -1 for
  /// none.
  std::vector<std::vector<int>> point_of_keypoint;
  /// Per point: part of the repeated facade pattern.
  std::vector<bool> repeated;
  /// Verified pairs: the shift (in houses) of the kept geometry (0 = true)
  /// and the fraction of inliers that are true matches.
  std::map<ImagePair, int> shift;
  std::map<ImagePair, double> true_fraction;
};

inline constexpr double kHouse = 4.0;
inline constexpr double kSpacing = 0.8;
inline constexpr double kFocal = 800.0;
inline constexpr int kWidth = 1024;
inline constexpr int kHeight = 768;

/// Writes the scene into a new database at `path`.
inline Scene Write(const std::string& path, const Options& options) {
  std::mt19937 rng(options.seed);
  std::uniform_real_distribution<double> uniform(0.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.5);
  Scene scene;

  struct Point {
    Eigen::Vector3d xyz;
    int appearance;
  };
  std::vector<Point> points;
  const double x_begin = -12.0;
  const double x_end = kSpacing * options.num_images + 12.0;
  const int num_houses = static_cast<int>(std::ceil((x_end - x_begin) / kHouse));
  constexpr int kPattern = 150;
  std::vector<Eigen::Vector3d> pattern(kPattern);  // (u, depth, z)
  for (Eigen::Vector3d& p : pattern) {
    p = Eigen::Vector3d(kHouse * uniform(rng), uniform(rng) < 0.5 ? 0.0 : 0.3,
                        0.1 + 5.2 * uniform(rng));
  }
  int next_appearance = kPattern;
  for (int h = 0; h < num_houses; ++h) {
    const double x0 = x_begin + h * kHouse;
    for (int k = 0; k < kPattern; ++k) {
      points.push_back({Eigen::Vector3d(x0 + pattern[k].x(),
                                        8.0 + pattern[k].y(), pattern[k].z()),
                        options.repeated ? k : next_appearance++});
      scene.repeated.push_back(options.repeated);
    }
    for (int k = 0; k < 10; ++k) {  // unique facade details
      points.push_back({Eigen::Vector3d(x0 + kHouse * uniform(rng), 7.95,
                                        0.1 + 1.9 * uniform(rng)),
                        next_appearance++});
      scene.repeated.push_back(false);
    }
    for (int k = 0; k < 40; ++k) {  // ground
      points.push_back({Eigen::Vector3d(x0 + kHouse * uniform(rng),
                                        3.5 + 4.4 * uniform(rng), 0.0),
                        next_appearance++});
      scene.repeated.push_back(false);
    }
  }

  // Cameras look along +y: camera x = world x, camera y = -world z.
  Eigen::Matrix3d R;
  R << 1, 0, 0, 0, 0, -1, 0, 1, 0;
  Eigen::Matrix3d K;
  K << kFocal, 0, kWidth / 2.0, 0, kFocal, kHeight / 2.0, 0, 0, 1;
  std::vector<Eigen::Vector3d> centers;
  for (int i = 0; i < options.num_images; ++i) {
    centers.emplace_back(kSpacing * i + 0.2 * (uniform(rng) - 0.5),
                         0.4 * (uniform(rng) - 0.5), 1.6);
  }

  DatabaseWriter writer(path);
  writer.WriteCamera(SimplePinholeCamera(1, kWidth, kHeight, kFocal));
  // Per image: keypoint of each point (-1 if not detected), and pixels.
  std::vector<std::vector<int>> keypoint_of(options.num_images);
  std::vector<std::vector<Eigen::Vector2d>> pixels(options.num_images);
  for (int i = 0; i < options.num_images; ++i) {
    const ImageId id = static_cast<ImageId>(i + 1);
    writer.WriteImage({id, "street" + std::to_string(id) + ".png", 1});
    keypoint_of[i].assign(points.size(), -1);
    std::vector<int> point_of;
    for (size_t p = 0; p < points.size(); ++p) {
      const Eigen::Vector3d Y = R * (points[p].xyz - centers[i]);
      if (Y.z() <= 0.5 || Y.z() > 20.0) continue;
      const Eigen::Vector2d uv = (K * Y).hnormalized();
      if (uv.x() < 0 || uv.y() < 0 || uv.x() > kWidth || uv.y() > kHeight ||
          uniform(rng) > 0.9) {
        continue;
      }
      keypoint_of[i][p] = static_cast<int>(point_of.size());
      point_of.push_back(static_cast<int>(p));
      pixels[i].push_back(uv + Eigen::Vector2d(noise(rng), noise(rng)));
    }
    Keypoints keypoints(pixels[i].size(), 2);
    for (size_t k = 0; k < pixels[i].size(); ++k) {
      keypoints.row(k) = pixels[i][k].cast<float>().transpose();
    }
    writer.WriteKeypoints(id, keypoints);
    scene.point_of_keypoint.push_back(point_of);
  }

  // Points of each appearance, for matching.
  std::map<int, std::vector<int>> by_appearance;
  for (size_t p = 0; p < points.size(); ++p) {
    by_appearance[points[p].appearance].push_back(static_cast<int>(p));
  }
  // The same-looking point of image b that appears most like p in image a.
  auto best_match = [&](int a, int b, int p) {
    int best = -1;
    double best_offset = 3.0;  // metres: beyond, the views differ too much
    const double offset_a = points[p].xyz.x() - centers[a].x();
    for (int q : by_appearance[points[p].appearance]) {
      if (keypoint_of[b][q] < 0) continue;
      const double d = std::abs(points[q].xyz.x() - centers[b].x() - offset_a);
      if (d < best_offset) {
        best_offset = d;
        best = q;
      }
    }
    return best;
  };
  for (int a = 0; a < options.num_images; ++a) {
    for (int b = a + 1; b < options.num_images; ++b) {
      if (centers[b].x() - centers[a].x() > 20.0) continue;
      std::vector<std::pair<int, int>> matches;  // points (p in a, q in b)
      std::map<int, int> support;                // shift -> matches
      for (size_t p = 0; p < points.size(); ++p) {
        if (keypoint_of[a][p] < 0) continue;
        const int q = best_match(a, b, static_cast<int>(p));
        if (q < 0 || best_match(b, a, q) != static_cast<int>(p)) continue;
        matches.push_back({static_cast<int>(p), q});
        ++support[static_cast<int>(
            std::lround((points[q].xyz.x() - points[p].xyz.x()) / kHouse))];
      }
      if (matches.empty()) continue;
      int shift = 0;
      for (const auto& [k, n] : support) {
        if (n > support[shift]) shift = k;
      }
      // Epipolar geometry of the shift: b seen as if moved back by it.
      const Eigen::Vector3d virtual_b =
          centers[b] - Eigen::Vector3d(kHouse * shift, 0, 0);
      const Eigen::Vector3d t = R * (centers[a] - virtual_b);
      if (t.norm() < 1e-3) continue;
      Eigen::Matrix3d tx;
      tx << 0, -t.z(), t.y(), t.z(), 0, -t.x(), -t.y(), t.x(), 0;
      const Eigen::Matrix3d E = tx / t.norm();  // relative rotation: identity
      const Eigen::Matrix3d F = K.inverse().transpose() * E * K.inverse();
      TwoViewGeometry g;
      g.pair = ImagePair(a + 1, b + 1);
      g.config = static_cast<int>(TwoViewConfig::kCalibrated);
      g.E = E;
      g.F = F;
      size_t num_true = 0;
      for (const auto& [p, q] : matches) {
        const Eigen::Vector3d x1 = pixels[a][keypoint_of[a][p]].homogeneous();
        const Eigen::Vector3d x2 = pixels[b][keypoint_of[b][q]].homogeneous();
        const Eigen::Vector3d Fx1 = F * x1;
        const Eigen::Vector3d Ftx2 = F.transpose() * x2;
        const double e = x2.dot(Fx1);
        const double sampson =
            e * e / (Fx1.head<2>().squaredNorm() + Ftx2.head<2>().squaredNorm());
        if (sampson > 16.0) continue;  // 4 px
        g.inlier_matches.push_back(
            {static_cast<Point2DIdx>(keypoint_of[a][p]),
             static_cast<Point2DIdx>(keypoint_of[b][q])});
        num_true += p == q;
      }
      if (g.inlier_matches.size() < 15) continue;
      writer.WriteTwoViewGeometry(g);
      scene.shift[g.pair] = shift;
      scene.true_fraction[g.pair] =
          static_cast<double>(num_true) / g.inlier_matches.size();
    }
  }
  writer.Close();
  return scene;
}

/// The repeated street of `num_images` photos written to a temporary folder
/// and opened, with its view graph (pairs of at least 15 inliers).
struct Opened {
  explicit Opened(uint32_t seed, int num_images = 16)
      : scene(Write(dir / "database.db", {num_images, true, seed})) {}
  TempDir dir{"hisfm-street"};
  Scene scene;
  Database db{dir / "database.db"};
  ViewGraph graph = ReadViewGraph(db, 15);
};

}  // namespace street_test
}  // namespace hisfm
