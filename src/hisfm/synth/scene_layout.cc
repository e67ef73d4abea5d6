#include "hisfm/synth/scene_layout.h"

#include <algorithm>
#include <cmath>

#include "hisfm/synth/scene_families.h"
#include "hisfm/synth/synth_random.h"
#include "hisfm/util/error.h"

namespace hisfm {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

// Object scenes.
constexpr double kObjectRadius = 1.0;
constexpr double kObjectHeight = 1.6;
constexpr int kObjectPoints = 2400;
constexpr double kWallRadius = 8.0;
constexpr double kWallHeight = 4.0;
constexpr int kWallPoints = 400;
constexpr int kGroundPoints = 400;
constexpr double kRingRadius = 4.0;
constexpr double kRingHeight = 1.4;
constexpr double kRingLookAtHeight = 0.8;

// Street scenes.
constexpr double kFacadeY = 8.0;
constexpr double kHouseWidth = 4.0;
constexpr double kFacadeHeight = 8.0;
constexpr double kWindowDepth = 0.3;
constexpr int kFacadePointsPerHouse = 260;
constexpr int kUniqueFacadePointsPerHouse = 20;
constexpr int kGroundPointsPerHouse = 60;
constexpr double kGroundYMin = -2.0;
constexpr double kCameraSpacing = 0.8;
constexpr double kStreetCameraHeight = 1.6;
constexpr double kStreetMargin = 10.0;

int Scaled(int count, double factor) {
  return static_cast<int>(std::lround(count * factor));
}

// Appearance ids are handed out in creation order.
class AppearanceCounter {
 public:
  uint32_t Next() { return next_++; }
  uint32_t Reserve(uint32_t n) {
    const uint32_t first = next_;
    next_ += n;
    return first;
  }

 private:
  uint32_t next_ = 0;
};

Eigen::Matrix3d RotationZ(double angle) {
  return Eigen::AngleAxisd(angle, Eigen::Vector3d::UnitZ()).toRotationMatrix();
}

void BuildObjectScene(const SynthOptions& options, SynthSceneType type,
                      SceneLayout* layout) {
  const int fold = type == SynthSceneType::kSymmetric4 ? 4 : 2;
  const bool repeated = type != SynthSceneType::kObjectControl;
  SynthRandom rng(DeriveSeed(options.seed, 1));
  AppearanceCounter appearance;

  // The object: one sector of the print, replicated `fold` times.
  const int per_sector = std::max(1, Scaled(kObjectPoints, options.object_density) / fold);
  const double sector = 2.0 * M_PI / fold;
  const double side_area = 2.0 * M_PI * kObjectRadius * kObjectHeight;
  const double top_area = M_PI * kObjectRadius * kObjectRadius;
  const double side_fraction = side_area / (side_area + top_area);
  std::vector<ScenePoint> motif;
  motif.reserve(per_sector);
  for (int i = 0; i < per_sector; ++i) {
    ScenePoint p;
    p.on_object = true;
    const double theta = rng.Uniform(0.0, sector);
    const Eigen::Vector3d radial(std::cos(theta), std::sin(theta), 0.0);
    if (rng.Uniform() < side_fraction) {
      const double z = rng.Uniform(0.05, kObjectHeight - 0.05);
      p.xyz = kObjectRadius * radial + Eigen::Vector3d(0, 0, z);
      p.normal = radial;
      p.tangent = Eigen::Vector3d::UnitZ();
    } else {
      const double rho = 0.97 * kObjectRadius * std::sqrt(rng.Uniform());
      p.xyz = rho * radial + Eigen::Vector3d(0, 0, kObjectHeight);
      p.normal = Eigen::Vector3d::UnitZ();
      p.tangent = radial;
    }
    motif.push_back(p);
  }
  const uint32_t motif_base = repeated ? appearance.Reserve(per_sector) : 0;
  for (int k = 0; k < fold; ++k) {
    const Eigen::Matrix3d R = RotationZ(k * sector);
    for (int i = 0; i < per_sector; ++i) {
      ScenePoint p = motif[i];
      p.xyz = R * p.xyz;
      p.normal = R * p.normal;
      p.tangent = R * p.tangent;
      p.replica = repeated ? k : 0;
      p.appearance = repeated ? motif_base + i : appearance.Next();
      layout->points.push_back(p);
    }
  }

  // Unique background: surrounding wall and ground.
  const int num_wall = Scaled(kWallPoints, options.background_density);
  for (int i = 0; i < num_wall; ++i) {
    ScenePoint p;
    const double theta = rng.Uniform(0.0, 2.0 * M_PI);
    const Eigen::Vector3d radial(std::cos(theta), std::sin(theta), 0.0);
    p.xyz = kWallRadius * radial +
            Eigen::Vector3d(0, 0, rng.Uniform(0.05, kWallHeight - 0.05));
    p.normal = -radial;
    p.tangent = Eigen::Vector3d::UnitZ();
    p.appearance = appearance.Next();
    layout->points.push_back(p);
  }
  const int num_ground = Scaled(kGroundPoints, options.background_density);
  const double r0 = 1.05 * kObjectRadius;
  for (int i = 0; i < num_ground; ++i) {
    ScenePoint p;
    const double theta = rng.Uniform(0.0, 2.0 * M_PI);
    const double rho = std::sqrt(
        r0 * r0 + rng.Uniform() * (kWallRadius * kWallRadius - r0 * r0) * 0.96);
    p.xyz = Eigen::Vector3d(rho * std::cos(theta), rho * std::sin(theta), 0.0);
    p.normal = Eigen::Vector3d::UnitZ();
    p.tangent = Eigen::Vector3d::UnitX();
    p.appearance = appearance.Next();
    layout->points.push_back(p);
  }

  // A ring of cameras looking at the object.
  const int n = options.num_images;
  for (int i = 0; i < n; ++i) {
    const double phi = 2.0 * M_PI * (i + rng.Uniform(-0.25, 0.25)) / n;
    const double radius = kRingRadius + rng.Uniform(-0.3, 0.3);
    const double height = kRingHeight + rng.Uniform(-0.3, 0.3);
    const Eigen::Vector3d center(radius * std::cos(phi),
                                 radius * std::sin(phi), height);
    // One draw per statement: the order of a call's arguments is the
    // compiler's (last first keeps the scenes of earlier builds).
    const double target_z = kRingLookAtHeight + rng.Normal(0.05);
    const double target_y = rng.Normal(0.05);
    const double target_x = rng.Normal(0.05);
    const Eigen::Vector3d target(target_x, target_y, target_z);
    layout->cams_from_world.push_back(LookAt(center, target, rng.Normal(2.0)));
  }

  layout->symmetry.type = repeated ? SymmetryGroup::Type::kRotationZ
                                   : SymmetryGroup::Type::kNone;
  layout->symmetry.order = repeated ? fold : 1;
  CylinderOccluder occluder;
  occluder.radius = kObjectRadius;
  occluder.z_min = 0.0;
  occluder.z_max = kObjectHeight;
  layout->occluders.push_back(occluder);
  // Cameras more than ~100 degrees apart on the ring share no matchable view.
  layout->pair_radius = 2.0 * (kRingRadius + 0.3) * std::sin(50.0 * kDegToRad);
  layout->max_view_distance = 2.0 * kWallRadius;
}

// Relief of the facade pattern: windows are recessed.
double FacadeRelief(double u, double z) {
  const bool window_column = (u > 0.6 && u < 1.6) || (u > 2.4 && u < 3.4);
  const double floor_z = std::fmod(z, 2.7);
  const bool window_row = z > 0.5 && floor_z > 1.0 && floor_z < 2.2;
  return window_column && window_row ? kWindowDepth : 0.0;
}

void BuildStreetScene(const SynthOptions& options, SynthSceneType type,
                      SceneLayout* layout) {
  const bool repeated = type == SynthSceneType::kStreet;
  SynthRandom rng(DeriveSeed(options.seed, 2));
  AppearanceCounter appearance;

  const int n = options.num_images;
  const double x_begin = -kStreetMargin;
  const double x_end = (n - 1) * kCameraSpacing + kStreetMargin;
  const int num_houses =
      static_cast<int>(std::ceil((x_end - x_begin) / kHouseWidth));
  const int block_houses = options.street_block_houses;
  const int num_blocks = (num_houses + block_houses - 1) / block_houses;
  const int per_house = std::max(1, Scaled(kFacadePointsPerHouse, options.object_density));

  // Facades: one random pattern per block, repeated on each of its houses.
  for (int b = 0; b < num_blocks; ++b) {
    std::vector<Eigen::Vector2d> pattern(per_house);  // (u, z) in a house
    for (Eigen::Vector2d& uz : pattern) {
      const double z = rng.Uniform(0.1, kFacadeHeight - 0.1);
      uz = Eigen::Vector2d(rng.Uniform(0.05, kHouseWidth - 0.05), z);
    }
    const uint32_t base = repeated ? appearance.Reserve(per_house) : 0;
    const int first_house = b * block_houses;
    const int last_house = std::min(num_houses, first_house + block_houses);
    for (int h = first_house; h < last_house; ++h) {
      const double x0 = x_begin + h * kHouseWidth;
      for (int i = 0; i < per_house; ++i) {
        ScenePoint p;
        p.on_object = true;
        const double u = pattern[i].x();
        const double z = pattern[i].y();
        p.xyz = Eigen::Vector3d(x0 + u, kFacadeY + FacadeRelief(u, z), z);
        p.normal = -Eigen::Vector3d::UnitY();
        p.tangent = Eigen::Vector3d::UnitX();
        p.replica = repeated ? h : 0;
        p.appearance = repeated ? base + i : appearance.Next();
        layout->points.push_back(p);
      }
    }
  }

  // Unique content: facade details (shop signs, doors) and the ground.
  const int unique_per_house =
      Scaled(kUniqueFacadePointsPerHouse, options.background_density);
  const int ground_per_house =
      Scaled(kGroundPointsPerHouse, options.background_density);
  for (int h = 0; h < num_houses; ++h) {
    const double x0 = x_begin + h * kHouseWidth;
    for (int i = 0; i < unique_per_house; ++i) {
      ScenePoint p;
      const double u = rng.Uniform(0.05, kHouseWidth - 0.05);
      const double z = rng.Uniform(0.1, 3.0);
      p.xyz = Eigen::Vector3d(x0 + u, kFacadeY - 0.05, z);
      p.normal = -Eigen::Vector3d::UnitY();
      p.tangent = Eigen::Vector3d::UnitX();
      p.appearance = appearance.Next();
      layout->points.push_back(p);
    }
    for (int i = 0; i < ground_per_house; ++i) {
      ScenePoint p;
      const double y = rng.Uniform(kGroundYMin, kFacadeY - 0.1);
      p.xyz = Eigen::Vector3d(x0 + rng.Uniform(0.0, kHouseWidth), y, 0.0);
      p.normal = Eigen::Vector3d::UnitZ();
      p.tangent = Eigen::Vector3d::UnitX();
      p.appearance = appearance.Next();
      layout->points.push_back(p);
    }
  }

  // A line of cameras along the street, looking at the facades.
  for (int i = 0; i < n; ++i) {
    const double z = kStreetCameraHeight + rng.Uniform(-0.1, 0.1);
    const double y = rng.Uniform(-0.3, 0.3);
    const Eigen::Vector3d center(i * kCameraSpacing + rng.Uniform(-0.15, 0.15),
                                 y, z);
    const double yaw = rng.Normal(5.0) * kDegToRad;
    const double pitch = (5.0 + rng.Normal(2.0)) * kDegToRad;
    const Eigen::Vector3d direction(std::sin(yaw), std::cos(yaw),
                                    std::tan(pitch));
    layout->cams_from_world.push_back(
        LookAt(center, center + direction, rng.Normal(1.0)));
  }

  layout->symmetry.type = repeated ? SymmetryGroup::Type::kTranslationX
                                   : SymmetryGroup::Type::kNone;
  layout->symmetry.period = kHouseWidth;
  layout->symmetry.max_shift = repeated ? block_houses - 1 : 0;
  // Facade points 8 m away seen under less than ~60 degrees.
  layout->pair_radius = 2.0 * kFacadeY * std::tan(30.0 * kDegToRad) + 1.0;
  layout->max_view_distance = 30.0;
}

}  // namespace

std::vector<int> SymmetryGroup::Elements() const {
  std::vector<int> elements = {0};
  if (type == Type::kRotationZ) {
    for (int k = 1; k < order; ++k) elements.push_back(k);
  } else if (type == Type::kTranslationX) {
    for (int k = 1; k <= max_shift; ++k) {
      elements.push_back(k);
      elements.push_back(-k);
    }
  } else if (type == Type::kReplicaFrames) {
    for (size_t k = 1; k < relations.size(); ++k) {
      elements.push_back(static_cast<int>(k));
    }
  }
  return elements;
}

Rigid3d SymmetryGroup::Transform(int k) const {
  Rigid3d g;
  if (type == Type::kRotationZ) {
    g.rotation = Eigen::Quaterniond(
        Eigen::AngleAxisd(2.0 * M_PI * k / order, Eigen::Vector3d::UnitZ()));
  } else if (type == Type::kTranslationX) {
    g.translation = Eigen::Vector3d(k * period, 0.0, 0.0);
  } else if (type == Type::kReplicaFrames) {
    g = relations.at(static_cast<size_t>(k));
  }
  return g;
}

int SymmetryGroup::Relation(int replica_p, int replica_q) const {
  if (type == Type::kRotationZ) {
    return ((replica_q - replica_p) % order + order) % order;
  }
  if (type == Type::kReplicaFrames) {
    return relation_table[static_cast<size_t>(replica_p) * replica_frames.size() +
                          static_cast<size_t>(replica_q)];
  }
  return replica_q - replica_p;
}

bool CylinderOccluder::Occludes(const Eigen::Vector3d& a,
                                const Eigen::Vector3d& b) const {
  // Parameter interval s in (0, 1) where a + s (b - a) is inside the solid.
  const Eigen::Vector3d d = b - a;
  double s0 = 1e-6, s1 = 1.0 - 1e-6;
  // Height slab.
  if (std::abs(d.z()) < 1e-12) {
    if (a.z() < z_min || a.z() > z_max) return false;
  } else {
    double t0 = (z_min - a.z()) / d.z();
    double t1 = (z_max - a.z()) / d.z();
    if (t0 > t1) std::swap(t0, t1);
    s0 = std::max(s0, t0);
    s1 = std::min(s1, t1);
    if (s0 >= s1) return false;
  }
  // Infinite cylinder: |(a - c) + s d|^2 < r^2 in xy.
  const Eigen::Vector2d o = a.head<2>() - center;
  const Eigen::Vector2d dxy = d.head<2>();
  const double qa = dxy.squaredNorm();
  const double qb = 2.0 * o.dot(dxy);
  const double qc = o.squaredNorm() - radius * radius;
  if (qa < 1e-12) return qc < 0.0;
  const double disc = qb * qb - 4.0 * qa * qc;
  if (disc <= 0.0) return false;
  const double root = std::sqrt(disc);
  const double t0 = (-qb - root) / (2.0 * qa);
  const double t1 = (-qb + root) / (2.0 * qa);
  return std::max(s0, t0) < std::min(s1, t1);
}

bool BoxOccluder::Occludes(const Eigen::Vector3d& a,
                           const Eigen::Vector3d& b) const {
  // Slab test in the box's frame over the parameter interval s in (0, 1).
  const double c = std::cos(yaw), s = std::sin(yaw);
  auto to_box = [&](const Eigen::Vector3d& x) {
    const Eigen::Vector2d d = x.head<2>() - center;
    return Eigen::Vector3d(c * d.x() + s * d.y(), -s * d.x() + c * d.y(), x.z());
  };
  const Eigen::Vector3d a_box = to_box(a);
  const Eigen::Vector3d dir = to_box(b) - a_box;
  const Eigen::Vector3d lo(-half_size.x(), -half_size.y(), z_min);
  const Eigen::Vector3d hi(half_size.x(), half_size.y(), z_max);
  double s0 = 1e-6, s1 = 1.0 - 1e-6;
  for (int axis = 0; axis < 3; ++axis) {
    if (std::abs(dir(axis)) < 1e-12) {
      if (a_box(axis) <= lo(axis) || a_box(axis) >= hi(axis)) return false;
      continue;
    }
    double t0 = (lo(axis) - a_box(axis)) / dir(axis);
    double t1 = (hi(axis) - a_box(axis)) / dir(axis);
    if (t0 > t1) std::swap(t0, t1);
    s0 = std::max(s0, t0);
    s1 = std::min(s1, t1);
    if (s0 >= s1) return false;
  }
  return true;
}

Rigid3d LookAt(const Eigen::Vector3d& center, const Eigen::Vector3d& target,
               double roll_deg) {
  const Eigen::Vector3d forward = (target - center).normalized();
  Eigen::Vector3d right = forward.cross(Eigen::Vector3d::UnitZ());
  if (right.norm() < 1e-9) right = Eigen::Vector3d::UnitX();
  right.normalize();
  const Eigen::Vector3d down = forward.cross(right);
  Eigen::Matrix3d R;
  R.row(0) = right;
  R.row(1) = down;
  R.row(2) = forward;
  R = Eigen::AngleAxisd(roll_deg * kDegToRad, Eigen::Vector3d::UnitZ())
          .toRotationMatrix() *
      R;
  Rigid3d cam_from_world;
  cam_from_world.rotation = Eigen::Quaterniond(R).normalized();
  cam_from_world.translation = -(R * center);
  return cam_from_world;
}

SceneLayout BuildSceneLayout(const SynthOptions& options) {
  options.Check();
  SceneLayout layout;
  layout.type = ParseSynthSceneType(options.scene);
  switch (layout.type) {
    case SynthSceneType::kSymmetric2:
    case SynthSceneType::kSymmetric4:
    case SynthSceneType::kObjectControl:
      BuildObjectScene(options, layout.type, &layout);
      break;
    case SynthSceneType::kStreet:
    case SynthSceneType::kStreetControl:
      BuildStreetScene(options, layout.type, &layout);
      break;
    case SynthSceneType::kFacadeStreet:
    case SynthSceneType::kBlockLoop:
    case SynthSceneType::kCrossingStreets:
    case SynthSceneType::kSymmetricObject:
      BuildFamilyLayout(options, layout.type, &layout);
      break;
  }
  return layout;
}

}  // namespace hisfm
