#include "hisfm/synth/scene_families.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "hisfm/synth/synthetic_matches.h"
#include "hisfm/util/error.h"

namespace hisfm {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

SynthOptions FamilyOptions(const std::string& scene, int num_images,
                           uint32_t seed = 7) {
  SynthOptions options;
  options.scene = scene;
  options.num_images = num_images;
  options.seed = seed;
  options.num_threads = 2;
  return options;
}

// Options without camera noise, for exact path checks.
SynthOptions ExactPathOptions(const std::string& scene, int num_images) {
  SynthOptions options = FamilyOptions(scene, num_images);
  options.family.position_jitter = 0.0;
  options.family.rotation_jitter = 0.0;
  return options;
}

std::vector<Eigen::Vector3d> Centers(const SceneLayout& layout) {
  std::vector<Eigen::Vector3d> centers;
  for (const Rigid3d& cam : layout.cams_from_world) {
    centers.push_back(cam.Inverse().translation);
  }
  return centers;
}

Eigen::Vector3d ViewAxis(const Rigid3d& cam_from_world) {
  return cam_from_world.rotation.toRotationMatrix().row(2).transpose();
}

std::vector<SynthPair> VerifiedPairs(const SyntheticScene& scene) {
  std::vector<SynthPair> pairs;
  ForEachSynthPair(scene, true, [&](const SynthPair& pair) {
    if (pair.verification.verified) pairs.push_back(pair);
  });
  return pairs;
}

// Points of repeated content grouped by appearance.
std::map<uint32_t, std::vector<const ScenePoint*>> RepeatedCopies(
    const SceneLayout& layout) {
  std::map<uint32_t, std::vector<const ScenePoint*>> copies;
  for (const ScenePoint& p : layout.points) {
    if (p.on_object) copies[p.appearance].push_back(&p);
  }
  return copies;
}

// Every two points with one appearance are related by the symmetry element
// of their replicas; returns the number of related pairs checked.
size_t CheckCopiesAreRelated(const SceneLayout& layout) {
  size_t checked = 0;
  for (const auto& [appearance, points] : RepeatedCopies(layout)) {
    for (size_t a = 1; a < points.size(); ++a) {
      const ScenePoint& p = *points[0];
      const ScenePoint& q = *points[a];
      const Rigid3d g = layout.symmetry.Transform(
          layout.symmetry.Relation(p.replica, q.replica));
      EXPECT_LT((g * p.xyz - q.xyz).norm(), 1e-6);
      EXPECT_LT((g.rotation * p.normal - q.normal).norm(), 1e-6);
      ++checked;
    }
  }
  return checked;
}

double SquaredSampsonError(const Eigen::Matrix3d& F, const Eigen::Vector2d& x1,
                           const Eigen::Vector2d& x2) {
  const Eigen::Vector3d Fx1 = F * x1.homogeneous();
  const Eigen::Vector3d Ftx2 = F.transpose() * x2.homogeneous();
  const double num = x2.homogeneous().dot(Fx1);
  return num * num /
         (Fx1.head<2>().squaredNorm() + Ftx2.head<2>().squaredNorm());
}

// Every inlier of a verified pair lies within max_error of its stored
// epipolar geometry (or homography for PLANAR_OR_PANORAMIC pairs).
void ExpectInliersFitTheGeometry(const SyntheticScene& scene,
                                 const SynthPair& pair) {
  const TwoViewGeometry& g = pair.verification.geometry;
  const SynthImage& image1 = scene.images[g.pair.image_id1 - 1];
  const SynthImage& image2 = scene.images[g.pair.image_id2 - 1];
  const double max_sq = std::pow(scene.options.max_error, 2) * (1.0 + 1e-6);
  const bool planar =
      g.config == static_cast<int>(TwoViewConfig::kPlanarOrPanoramic);
  for (const FeatureMatch& m : g.inlier_matches) {
    const Eigen::Vector2d x1 = image1.features[m.idx1].xy.cast<double>();
    const Eigen::Vector2d x2 = image2.features[m.idx2].xy.cast<double>();
    const bool fits_f = SquaredSampsonError(g.F, x1, x2) <= max_sq;
    const bool fits_h =
        planar &&
        ((g.H * x1.homogeneous()).hnormalized() - x2).squaredNorm() <= max_sq;
    EXPECT_TRUE(fits_f || fits_h);
  }
}

TEST(FacadeStreet, CamerasFollowTheStreetAtTheSpacing) {
  SynthOptions options = FamilyOptions("facade_street", 20);
  options.family.camera_spacing = 1.5;
  options.family.facade_distance = 8.0;
  options.family.position_jitter = 0.05;
  options.family.rotation_jitter = 1.0;
  const SceneLayout layout = BuildSceneLayout(options);
  const std::vector<Eigen::Vector3d> centers = Centers(layout);
  ASSERT_EQ(centers.size(), 20u);
  for (size_t i = 0; i < centers.size(); ++i) {
    EXPECT_NEAR(centers[i].x(), 1.5 * i, 0.25);
    EXPECT_NEAR(centers[i].y(), 0.0, 0.25);
    EXPECT_NEAR(centers[i].z(), 1.6, 0.15);
    // Looking at the facade (+y), pitched up by about 8 degrees.
    const Eigen::Vector3d axis = ViewAxis(layout.cams_from_world[i]);
    EXPECT_GT(axis.y(), std::cos(15.0 * kDegToRad));
    EXPECT_NEAR(std::asin(axis.z()) / kDegToRad, 8.0, 5.0);
  }
  EXPECT_NEAR((centers.back().x() - centers.front().x()) / 19.0, 1.5, 0.02);
  // The facade lies at facade_distance and reaches past both ends.
  double x_min = 1e9, x_max = -1e9;
  for (const ScenePoint& p : layout.points) {
    if (!p.on_object) continue;
    EXPECT_NEAR(p.xyz.y(), 8.0, 1e-9);  // planar by default
    x_min = std::min(x_min, p.xyz.x());
    x_max = std::max(x_max, p.xyz.x());
  }
  EXPECT_LT(x_min, centers.front().x() - 5.0);
  EXPECT_GT(x_max, centers.back().x() + 5.0);
}

TEST(FacadeStreet, PatternRepeatsWithThePeriod) {
  SynthOptions options = FamilyOptions("facade_street", 20);
  options.family.period = 3.0;
  options.family.relief_depth = 0.8;
  const SceneLayout layout = BuildSceneLayout(options);
  ASSERT_EQ(layout.symmetry.type, SymmetryGroup::Type::kReplicaFrames);
  const size_t num_copies = layout.symmetry.replica_frames.size();
  ASSERT_GT(num_copies, 5u);
  const auto copies = RepeatedCopies(layout);
  for (const auto& [appearance, points] : copies) {
    // One copy of each motif point per period, P apart along x.
    ASSERT_EQ(points.size(), num_copies);
    for (size_t k = 1; k < points.size(); ++k) {
      EXPECT_NEAR(points[k]->xyz.x() - points[k - 1]->xyz.x(), 3.0, 1e-9);
      EXPECT_NEAR(points[k]->xyz.y(), points[0]->xyz.y(), 1e-9);
      EXPECT_NEAR(points[k]->xyz.z(), points[0]->xyz.z(), 1e-9);
    }
  }
  EXPECT_GT(CheckCopiesAreRelated(layout), 1000u);
  // Unique clutter: no appearance shared.
  std::set<uint32_t> clutter;
  for (const ScenePoint& p : layout.points) {
    if (p.clutter) {
      EXPECT_TRUE(clutter.insert(p.appearance).second);
    }
  }
  EXPECT_GT(clutter.size(), 100u);
}

TEST(FacadeStreet, ReliefMovesPatternPointsOffThePlane) {
  SynthOptions options = FamilyOptions("facade_street", 10);
  options.family.relief_depth = 1.2;
  const double d = options.family.facade_distance;
  const SceneLayout layout = BuildSceneLayout(options);
  size_t facade = 0, off_plane = 0, sides = 0;
  double protrusion = 0.0, recess = 0.0;
  for (const ScenePoint& p : layout.points) {
    if (!p.on_object) continue;
    ++facade;
    const double offset = p.xyz.y() - d;  // > 0: recessed
    protrusion = std::max(protrusion, -offset);
    recess = std::max(recess, offset);
    if (std::abs(offset) > 1e-9) ++off_plane;
    if (std::abs(p.normal.x()) > 0.99) ++sides;
  }
  EXPECT_NEAR(protrusion, 1.2, 1e-9);  // balconies
  EXPECT_NEAR(recess, 0.36, 1e-9);     // windows
  EXPECT_GT(off_plane, facade / 4);
  EXPECT_GT(sides, facade / 50);  // pillar, window and balcony sides
}

TEST(FacadeStreet, ClutterDensityFollowsTheOption) {
  for (const double density : {0.1, 0.45}) {
    SynthOptions options = FamilyOptions("facade_street", 30);
    options.family.clutter_density = density;
    const SyntheticScene scene = GenerateScene(options);
    size_t facade = 0, clutter = 0;
    for (const ScenePoint& p : scene.layout.points) {
      if (p.on_object) ++facade;
      if (p.clutter) {
        ++clutter;
        // Between the camera path and the facade.
        EXPECT_GT(p.xyz.y(), 0.5);
        EXPECT_LT(p.xyz.y(), options.family.facade_distance);
      }
    }
    EXPECT_NEAR(static_cast<double>(clutter) / facade, density, 0.01);
    EXPECT_FALSE(scene.layout.occluders.empty() && scene.layout.boxes.empty());
    // The images see a smaller ratio: far sides of the clutter are hidden.
    size_t seen_facade = 0, seen_clutter = 0;
    for (const SynthImage& image : scene.images) {
      for (const SynthFeature& f : image.features) {
        if (f.point_index == kNoScenePoint) continue;
        const ScenePoint& p = scene.layout.points[f.point_index];
        seen_facade += p.on_object;
        seen_clutter += p.clutter;
      }
    }
    const double seen = static_cast<double>(seen_clutter) / seen_facade;
    EXPECT_GT(seen, 0.15 * density);
    EXPECT_LT(seen, density);
  }
}

TEST(FacadeStreet, ClutterHidesTheFacade) {
  SynthOptions options = FamilyOptions("facade_street", 20);
  options.family.clutter_density = 0.5;
  const SyntheticScene scene = GenerateScene(options);
  size_t facade_seen = 0;
  for (const SynthImage& image : scene.images) {
    const Eigen::Vector3d center = image.cam_from_world.Inverse().translation;
    for (const SynthFeature& f : image.features) {
      if (f.point_index == kNoScenePoint) continue;
      const ScenePoint& p = scene.layout.points[f.point_index];
      if (!p.on_object) continue;
      ++facade_seen;
      for (const BoxOccluder& box : scene.layout.boxes) {
        EXPECT_FALSE(box.Occludes(center, p.xyz));
      }
      for (const CylinderOccluder& c : scene.layout.occluders) {
        EXPECT_FALSE(c.Occludes(center, p.xyz));
      }
    }
  }
  EXPECT_GT(facade_seen, 20u * 200u);
}

TEST(FacadeStreet, VerificationKeepsWrongMatchesOnTheEpipolarLines) {
  // The planar facade of the shared facade_street_60 scene: true pairs keep
  // doppelganger inliers, distant pairs are pure doppelgangers with about
  // as many inliers as true neighbours.
  const SyntheticScene scene =
      GenerateScene(FamilyOptions("facade_street", 40));
  const std::vector<Eigen::Vector3d> centers = Centers(scene.layout);
  size_t near_pairs = 0, near_mixed = 0, far_pairs = 0, not_calibrated = 0;
  std::vector<size_t> neighbour_inliers;
  for (const SynthPair& pair : VerifiedPairs(scene)) {
    ExpectInliersFitTheGeometry(scene, pair);
    const SynthVerification& v = pair.verification;
    EXPECT_EQ(
        v.num_true_inliers + v.num_doppelganger_inliers + v.num_random_inliers,
        v.geometry.inlier_matches.size());
    if (v.geometry.config != static_cast<int>(TwoViewConfig::kCalibrated)) {
      ++not_calibrated;
    }
    const ImagePair& p = pair.matches.pair;
    const double distance =
        (centers[p.image_id1 - 1] - centers[p.image_id2 - 1]).norm();
    if (distance < 1.5)
      neighbour_inliers.push_back(v.geometry.inlier_matches.size());
    if (distance < 3.0 && v.num_true_inliers > v.num_doppelganger_inliers) {
      ++near_pairs;
      if (v.num_doppelganger_inliers > 0) ++near_mixed;
    }
    if (distance > 20.0) {
      ++far_pairs;
      EXPECT_EQ(v.num_true_inliers, 0u);
      EXPECT_TRUE(v.MostlyDoppelganger());
    }
  }
  ASSERT_FALSE(neighbour_inliers.empty());
  std::sort(neighbour_inliers.begin(), neighbour_inliers.end());
  const size_t median = neighbour_inliers[neighbour_inliers.size() / 2];
  EXPECT_GT(near_pairs, 40u);
  EXPECT_GT(near_mixed, near_pairs / 3);
  // Every pair of images 20 m apart is a verified doppelganger pair.
  size_t far_candidates = 0;
  for (size_t i = 0; i < centers.size(); ++i) {
    for (size_t j = i + 1; j < centers.size(); ++j) {
      if ((centers[i] - centers[j]).norm() > 20.0) ++far_candidates;
    }
  }
  EXPECT_EQ(far_pairs, far_candidates);
  EXPECT_GT(not_calibrated, 100u);
  // Distant doppelgangers are about as strong as true neighbours.
  double far_sum = 0.0;
  for (const SynthPair& pair : VerifiedPairs(scene)) {
    const ImagePair& p = pair.matches.pair;
    if ((centers[p.image_id1 - 1] - centers[p.image_id2 - 1]).norm() > 20.0) {
      const size_t inliers = pair.verification.geometry.inlier_matches.size();
      EXPECT_GT(inliers, median / 4);
      far_sum += inliers;
    }
  }
  EXPECT_GT(far_sum / far_pairs, 0.6 * median);
}

TEST(FacadeStreet, ControlHasNoRepeatedContent) {
  SynthOptions options = FamilyOptions("facade_street", 30);
  options.family.unique_pattern = true;
  const SyntheticScene scene = GenerateScene(options);
  std::set<uint32_t> appearances;
  for (const ScenePoint& p : scene.layout.points) {
    EXPECT_TRUE(appearances.insert(p.appearance).second);
  }
  EXPECT_EQ(scene.layout.symmetry.Elements().size(), 1u);
  const std::vector<Eigen::Vector3d> centers = Centers(scene.layout);
  size_t verified = 0;
  for (const SynthPair& pair : VerifiedPairs(scene)) {
    ++verified;
    EXPECT_EQ(pair.matches.NumDoppelgangerMatches(), 0u);
    EXPECT_EQ(pair.verification.num_doppelganger_inliers, 0u);
    EXPECT_EQ(pair.verification.hypothesis, 0);
    const ImagePair& p = pair.matches.pair;
    EXPECT_LT((centers[p.image_id1 - 1] - centers[p.image_id2 - 1]).norm(),
              12.0);
  }
  EXPECT_GT(verified, 100u);
}

TEST(FacadeStreet, BlocksHaveTheirOwnPattern) {
  SynthOptions options = FamilyOptions("facade_street", 40);
  options.family.period = 4.0;
  options.family.block_length = 16.0;
  const SceneLayout layout = BuildSceneLayout(options);
  const double x0 = layout.symmetry.replica_frames.front().translation.x();
  for (const auto& [appearance, points] : RepeatedCopies(layout)) {
    // Four periods per block, all in the block of the first copy.
    EXPECT_LE(points.size(), 4u);
    const int block =
        static_cast<int>(std::floor((points[0]->xyz.x() - x0) / 16.0));
    for (const ScenePoint* p : points) {
      EXPECT_EQ(static_cast<int>(std::floor((p->xyz.x() - x0) / 16.0)), block);
    }
  }
}

// Distance from a point to the boundary of the rectangle |x| <= a, |y| <= b
// (the point being outside).
double DistanceToRectangle(const Eigen::Vector2d& p, double a, double b) {
  const double dx = std::max(0.0, std::abs(p.x()) - a);
  const double dy = std::max(0.0, std::abs(p.y()) - b);
  return std::hypot(dx, dy);
}

TEST(BlockLoop, CamerasWalkAClosedLoopAroundTheBlock) {
  SynthOptions options = ExactPathOptions("block_loop", 60);
  options.family.block_aspect = 0.5;
  const SceneLayout layout = BuildSceneLayout(options);
  // The block's half sides from the frames of the pattern copies.
  double a = 0.0, b = 0.0;
  for (const Rigid3d& frame : layout.symmetry.replica_frames) {
    a = std::max(a, std::abs(frame.translation.x()));
    b = std::max(b, std::abs(frame.translation.y()));
  }
  EXPECT_NEAR(std::min(a, b) / std::max(a, b), 0.5, 0.2);
  const double spacing = layout.family_options.camera_spacing;
  const double d = options.family.facade_distance;
  const std::vector<Eigen::Vector3d> centers = Centers(layout);
  double winding = 0.0;
  for (size_t i = 0; i < centers.size(); ++i) {
    const Eigen::Vector3d& c = centers[i];
    const Eigen::Vector3d& next = centers[(i + 1) % centers.size()];
    // Equal steps, the last one closing the loop (chords on the corners).
    EXPECT_NEAR((next - c).norm(), spacing, 0.01 * spacing);
    EXPECT_NEAR(DistanceToRectangle(c.head<2>(), a, b), d, 1e-6);
    // Looking at the block.
    EXPECT_LT(ViewAxis(layout.cams_from_world[i]).head<2>().dot(c.head<2>()),
              0.0);
    winding += std::remainder(
        std::atan2(next.y(), next.x()) - std::atan2(c.y(), c.x()), 2.0 * M_PI);
  }
  EXPECT_NEAR(winding, 2.0 * M_PI, 1e-6);
  // The loop is num_images * camera_spacing long when the block allows it.
  EXPECT_NEAR(spacing, options.family.camera_spacing, 0.1);
}

TEST(BlockLoop, AllSidesAndCornersCarryThePattern) {
  const SceneLayout layout = BuildSceneLayout(FamilyOptions("block_loop", 80));
  EXPECT_GT(CheckCopiesAreRelated(layout), 1000u);
  // Orientation of each copy: the four sides and the corners.
  auto yaw_of = [&](const ScenePoint& p) {
    const Eigen::Matrix3d R =
        layout.symmetry.replica_frames[p.replica].rotation.toRotationMatrix();
    return static_cast<int>(
        std::lround(std::atan2(R(1, 0), R(0, 0)) / (0.5 * M_PI)));
  };
  size_t on_four_sides = 0, corner_points = 0;
  const auto copies = RepeatedCopies(layout);
  for (const auto& [appearance, points] : copies) {
    std::set<int> sides;
    for (const ScenePoint* p : points) sides.insert(yaw_of(*p));
    if (sides.size() == 4) ++on_four_sides;
    // Corner pillars: one copy per corner, at the corners.
    const Eigen::Vector3d origin =
        layout.symmetry.replica_frames[points[0]->replica].translation;
    bool at_corner = true;
    for (const ScenePoint* p : points) {
      const Eigen::Vector3d o =
          layout.symmetry.replica_frames[p->replica].translation;
      at_corner = at_corner &&
                  std::abs(std::abs(o.x()) - std::abs(origin.x())) < 1e-9 &&
                  std::abs(std::abs(o.y()) - std::abs(origin.y())) < 1e-9;
    }
    if (at_corner && points.size() == 4) ++corner_points;
  }
  EXPECT_GT(on_four_sides, copies.size() * 9 / 10);
  EXPECT_GT(corner_points, 20u);
}

TEST(BlockLoop, OppositeSidesAreDoppelgangersExceptInTheControl) {
  for (const bool unique : {false, true}) {
    SynthOptions options = FamilyOptions("block_loop", 40);
    options.family.unique_pattern = unique;
    const SyntheticScene scene = GenerateScene(options);
    size_t opposite = 0, doppelgangers = 0, verified = 0;
    for (const SynthPair& pair : VerifiedPairs(scene)) {
      ++verified;
      ExpectInliersFitTheGeometry(scene, pair);
      const ImagePair& p = pair.matches.pair;
      const double facing =
          ViewAxis(scene.images[p.image_id1 - 1].cam_from_world)
              .dot(ViewAxis(scene.images[p.image_id2 - 1].cam_from_world));
      if (pair.verification.MostlyDoppelganger()) ++doppelgangers;
      if (facing < -0.5) {
        ++opposite;
        EXPECT_TRUE(pair.verification.MostlyDoppelganger());
      }
      if (unique) {
        EXPECT_EQ(pair.matches.NumDoppelgangerMatches(), 0u);
      }
    }
    EXPECT_GT(verified, 100u);
    if (unique) {
      EXPECT_EQ(doppelgangers, 0u);
      EXPECT_EQ(opposite, 0u);
    } else {
      EXPECT_GT(opposite, 20u);
      EXPECT_GT(doppelgangers, verified / 3);
    }
  }
}

TEST(CrossingStreets, CamerasWalkBothStreets) {
  SynthOptions options = ExactPathOptions("crossing_streets", 30);
  options.family.camera_spacing = 1.2;
  options.family.view_angle = 50.0;
  const SceneLayout layout = BuildSceneLayout(options);
  const std::vector<Eigen::Vector3d> centers = Centers(layout);
  for (size_t i = 0; i < centers.size(); ++i) {
    const bool on_a = i < 15;
    const Eigen::Vector3d ahead =
        on_a ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
    const Eigen::Vector3d across =
        on_a ? Eigen::Vector3d::UnitY() : Eigen::Vector3d::UnitX();
    EXPECT_NEAR(centers[i].dot(across), 0.0, 1e-9);
    EXPECT_NEAR(centers[i].dot(ahead), 1.2 * ((on_a ? i : i - 15) - 7.0), 1e-9);
    // view_angle from the street, A to its left (+y), B to its right (+x).
    const Eigen::Vector3d axis = ViewAxis(layout.cams_from_world[i]);
    const double angle =
        std::atan2(axis.dot(across), axis.dot(ahead)) / kDegToRad;
    EXPECT_NEAR(angle, 50.0, 1e-6);
  }
}

TEST(CrossingStreets, BothSidesOfBothStreetsShareThePattern) {
  const SceneLayout layout =
      BuildSceneLayout(FamilyOptions("crossing_streets", 60));
  EXPECT_GT(CheckCopiesAreRelated(layout), 1000u);
  // Facades facing each way.
  std::set<std::pair<int, int>> normals;
  size_t on_both_streets = 0;
  const auto copies = RepeatedCopies(layout);
  for (const auto& [appearance, points] : copies) {
    bool on_a = false, on_b = false;
    for (const ScenePoint* p : points) {
      const Eigen::Vector3d& n = p->normal;
      if (std::abs(n.z()) > 0.5) continue;
      normals.insert({static_cast<int>(std::lround(n.x())),
                      static_cast<int>(std::lround(n.y()))});
      // Front faces of street A face +-y, those of street B +-x.
      on_a = on_a || std::abs(std::abs(p->xyz.y()) - 6.0) < 1e-9;
      on_b = on_b || std::abs(std::abs(p->xyz.x()) - 6.0) < 1e-9;
    }
    if (on_a && on_b) ++on_both_streets;
  }
  EXPECT_EQ(normals.size(), 4u);
  EXPECT_GT(on_both_streets, copies.size() / 2);
}

TEST(CrossingStreets, DoppelgangersAcrossTheStreetsExceptInTheControl) {
  for (const bool unique : {false, true}) {
    SynthOptions options = FamilyOptions("crossing_streets", 40);
    options.family.unique_pattern = unique;
    const SyntheticScene scene = GenerateScene(options);
    size_t across = 0, verified = 0;
    for (const SynthPair& pair : VerifiedPairs(scene)) {
      ++verified;
      ExpectInliersFitTheGeometry(scene, pair);
      const ImagePair& p = pair.matches.pair;
      const bool a1 = p.image_id1 <= 20, a2 = p.image_id2 <= 20;
      if (a1 != a2 && pair.verification.MostlyDoppelganger()) ++across;
      if (unique) {
        EXPECT_EQ(pair.verification.num_doppelganger_inliers, 0u);
      }
    }
    EXPECT_GT(verified, 100u);
    if (unique) {
      EXPECT_EQ(across, 0u);
    } else {
      EXPECT_GT(across, 20u);
    }
  }
}

TEST(SymmetricObject, PrintRepeatsSymmetryOrderTimes) {
  for (const int order : {2, 3, 4}) {
    SynthOptions options = ExactPathOptions("symmetric_object", 24);
    options.family.symmetry_order = order;
    options.family.ring_radius = 5.0;
    const SceneLayout layout = BuildSceneLayout(options);
    ASSERT_EQ(layout.symmetry.type, SymmetryGroup::Type::kRotationZ);
    for (const auto& [appearance, points] : RepeatedCopies(layout)) {
      ASSERT_EQ(points.size(), static_cast<size_t>(order));
      const Eigen::AngleAxisd step(2.0 * M_PI / order,
                                   Eigen::Vector3d::UnitZ());
      for (int k = 1; k < order; ++k) {
        EXPECT_LT((step * points[k - 1]->xyz - points[k]->xyz).norm(), 1e-9);
      }
    }
    EXPECT_GT(CheckCopiesAreRelated(layout), 1000u);
    for (const Eigen::Vector3d& c : Centers(layout)) {
      EXPECT_NEAR(c.head<2>().norm(), 5.0, 1e-9);
    }
  }
}

TEST(SymmetricObject, BackgroundDensityAndDoppelgangers) {
  for (const double density : {0.1, 0.8}) {
    for (const bool unique : {false, true}) {
      SynthOptions options = FamilyOptions("symmetric_object", 24);
      options.family.clutter_density = density;
      options.family.unique_pattern = unique;
      const SyntheticScene scene = GenerateScene(options);
      size_t object = 0, background = 0;
      for (const ScenePoint& p : scene.layout.points) {
        object += p.on_object;
        background += p.clutter;
      }
      EXPECT_NEAR(static_cast<double>(background) / object, density, 0.01);
      size_t doppelgangers = 0, verified = 0;
      for (const SynthPair& pair : VerifiedPairs(scene)) {
        ++verified;
        if (pair.verification.MostlyDoppelganger()) ++doppelgangers;
      }
      EXPECT_GT(verified, 30u);
      if (unique) {
        EXPECT_EQ(doppelgangers, 0u);
      } else {
        EXPECT_GT(doppelgangers, 10u);
      }
    }
  }
}

TEST(FamilyParameters, RandomizedWithinRangesAndDifferAcrossSeeds) {
  std::set<double> periods, distances;
  std::set<int> orders;
  for (uint32_t seed = 1; seed <= 40; ++seed) {
    SynthOptions options = FamilyOptions("facade_street", 40, seed);
    options.family.randomize = true;
    options.family.block_length = 24.0;
    const SynthFamilyOptions f = ResolveFamilyOptions(options);
    EXPECT_FALSE(f.randomize);
    EXPECT_GE(f.period, 2.0);
    EXPECT_LE(f.period, 8.0);
    EXPECT_GE(f.camera_spacing, 0.5);
    EXPECT_LE(f.camera_spacing, 2.0);
    EXPECT_GE(f.period / f.camera_spacing, 2.0 - 1e-9);
    EXPECT_LE(f.period / f.camera_spacing, 10.0 + 1e-9);
    EXPECT_GE(f.relief_depth, 0.0);
    EXPECT_LE(f.relief_depth, 1.5);
    EXPECT_GE(f.clutter_density, 0.1);
    EXPECT_LE(f.clutter_density, 0.5);
    EXPECT_GE(f.facade_distance, 5.0);
    EXPECT_LE(f.facade_distance, 15.0);
    EXPECT_LE(f.position_jitter, 0.2);
    EXPECT_LE(f.rotation_jitter, 4.0);
    EXPECT_GE(f.block_aspect, 0.5);
    EXPECT_GE(f.view_angle, 40.0);
    EXPECT_LE(f.view_angle, 60.0);
    EXPECT_GE(f.ring_radius, 3.0);
    EXPECT_LE(f.ring_radius, 6.0);
    EXPECT_NO_THROW(f.Check());
    // Parameters that are not drawn are kept.
    EXPECT_EQ(f.block_length, 24.0);
    periods.insert(f.period);
    distances.insert(f.facade_distance);
    orders.insert(f.symmetry_order);
    // The number of images plays no part; the seed alone decides.
    SynthOptions other_size = options;
    other_size.num_images = 150;
    const SynthFamilyOptions g = ResolveFamilyOptions(other_size);
    EXPECT_EQ(g.period, f.period);
    EXPECT_EQ(g.relief_depth, f.relief_depth);
  }
  EXPECT_GT(periods.size(), 35u);
  EXPECT_GT(distances.size(), 35u);
  EXPECT_EQ(orders, (std::set<int>{2, 3, 4}));
}

TEST(FamilyParameters, SeedsGiveDifferentGeometry) {
  std::vector<SceneLayout> layouts;
  for (const uint32_t seed : {3u, 4u}) {
    SynthOptions options = FamilyOptions("facade_street", 12, seed);
    options.family.randomize = true;
    layouts.push_back(BuildSceneLayout(options));
    const SceneLayout& layout = layouts.back();
    // The copies follow the drawn period, the cameras the drawn spacing.
    const std::vector<Rigid3d>& frames = layout.symmetry.replica_frames;
    EXPECT_NEAR(frames[1].translation.x() - frames[0].translation.x(),
                layout.family_options.period, 1e-9);
    const std::vector<Eigen::Vector3d> centers = Centers(layout);
    EXPECT_NEAR((centers.back().x() - centers.front().x()) / 11.0,
                layout.family_options.camera_spacing, 0.1);
  }
  EXPECT_NE(layouts[0].family_options.period, layouts[1].family_options.period);
  EXPECT_NE(layouts[0].points.size(), layouts[1].points.size());
}

TEST(FamilyParameters, CheckRejectsInvalidValues) {
  auto rejects = [](auto change, const std::string& name) {
    SynthOptions options = FamilyOptions("facade_street", 10);
    change(&options.family);
    try {
      options.Check();
      ADD_FAILURE() << "accepted invalid " << name;
    } catch (const Error& e) {
      const std::string message = e.what();
      EXPECT_NE(message.find(name), std::string::npos) << message;
      EXPECT_EQ(message.find('\n'), std::string::npos);
    }
  };
  rejects([](SynthFamilyOptions* f) { f->period = 0.5; }, "period");
  rejects([](SynthFamilyOptions* f) { f->camera_spacing = 0.0; },
          "camera_spacing");
  rejects([](SynthFamilyOptions* f) { f->facade_distance = 2.0; },
          "facade_distance");
  rejects([](SynthFamilyOptions* f) { f->relief_depth = -0.1; },
          "relief_depth");
  rejects([](SynthFamilyOptions* f) { f->clutter_density = -1.0; },
          "clutter_density");
  rejects([](SynthFamilyOptions* f) { f->block_length = 1.0; }, "block_length");
  rejects([](SynthFamilyOptions* f) { f->symmetry_order = 1; },
          "symmetry_order");
  rejects([](SynthFamilyOptions* f) { f->view_angle = 10.0; }, "view_angle");
  EXPECT_TRUE(IsSynthFamily(ParseSynthSceneType("crossing_streets")));
  EXPECT_FALSE(IsSynthFamily(ParseSynthSceneType("street")));
}

TEST(FamilyParameters, TooManyCopiesIsAnError) {
  SynthOptions options = FamilyOptions("facade_street", 4000);
  options.family.period = 1.0;
  options.family.camera_spacing = 2.0;
  EXPECT_THROW(BuildSceneLayout(options), Error);
}

}  // namespace
}  // namespace hisfm
