#include "hisfm/synth/scene_families.h"

#include <Eigen/Geometry>
#include <algorithm>
#include <array>
#include <cmath>
#include <map>

#include "hisfm/synth/synth_random.h"
#include "hisfm/util/error.h"

namespace hisfm {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

// Streets.
constexpr double kFacadeHeight = 12.0;
constexpr double kFloorHeight = 3.0;
// Facade points per image area seen head-on from facade_distance.
constexpr double kFacadePointsPerHeadOnImage = 800.0;
constexpr double kCameraHeight = 1.6;
constexpr double kCameraPitchDeg = 8.0;
// Half width of the corner pillar along each face.
constexpr double kCornerWidth = 0.8;
// One clutter object per this many metres of facade.
constexpr double kClutterSpacing = 5.0;
// Clutter stands within this fraction of facade_distance from the facade.
constexpr double kClutterZone = 0.6;

// symmetric_object (the geometry of hisfm/synth/scene_layout.cc's objects).
constexpr double kObjectRadius = 1.0;
constexpr double kObjectHeight = 1.6;
constexpr int kObjectPoints = 2400;
constexpr double kWallHeight = 4.0;
constexpr double kRingHeight = 1.4;
constexpr double kRingLookAtHeight = 0.8;

// Random streams (second key of DeriveSeed).
enum Stream : uint64_t {
  kStreamParameters = 0,
  kStreamClutter = 1,
  kStreamGround = 2,
  kStreamCameras = 3,
  kStreamObject = 4,
  kStreamMotifs = 1000,
};

uint32_t FamilySeed(const SynthOptions& options, SynthSceneType type,
                    uint64_t stream) {
  return DeriveSeed(options.seed, 100 + static_cast<uint64_t>(type), stream);
}

// `value` rounded to `decimals` decimals (the nearest double: 0.95, not
// 95 * 0.01).
double RoundTo(double value, int decimals) {
  const double scale = std::pow(10.0, decimals);
  return std::round(value * scale) / scale;
}

// A point of a motif in the motif's frame (or of a unique surface in the
// world frame).
struct SurfacePoint {
  Eigen::Vector3d xyz = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d tangent = Eigen::Vector3d::UnitX();
};

// A textured rectangle origin + U a + V b (U, V in [0, 1)).
struct Rect {
  Eigen::Vector3d origin = Eigen::Vector3d::Zero();
  Eigen::Vector3d a = Eigen::Vector3d::UnitX();
  Eigen::Vector3d b = Eigen::Vector3d::UnitY();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitZ();
  Eigen::Vector3d tangent = Eigen::Vector3d::UnitX();
};

// The textured side of a vertical cylinder.
struct CylinderSide {
  Eigen::Vector2d center = Eigen::Vector2d::Zero();
  double radius = 1.0;
  double z_min = 0.0;
  double z_max = 1.0;
};

// Surfaces sampled by area.
struct SurfaceSet {
  std::vector<Rect> rects;
  std::vector<CylinderSide> cylinders;

  double Area(size_t k) const {
    if (k < rects.size()) return rects[k].a.norm() * rects[k].b.norm();
    const CylinderSide& c = cylinders[k - rects.size()];
    return 2.0 * M_PI * c.radius * (c.z_max - c.z_min);
  }
  size_t Size() const { return rects.size() + cylinders.size(); }
  double TotalArea() const {
    double total = 0.0;
    for (size_t k = 0; k < Size(); ++k) total += Area(k);
    return total;
  }

  // `count` points spread uniformly over the surfaces.
  std::vector<SurfacePoint> Sample(size_t count, SynthRandom* rng) const {
    std::vector<SurfacePoint> points;
    if (Size() == 0) return points;
    std::vector<double> cumulative(Size());
    double total = 0.0;
    for (size_t k = 0; k < Size(); ++k) cumulative[k] = total += Area(k);
    points.reserve(count);
    for (size_t i = 0; i < count; ++i) {
      const double x = rng->Uniform(0.0, total);
      const size_t k = std::min<size_t>(
          Size() - 1,
          std::upper_bound(cumulative.begin(), cumulative.end(), x) -
              cumulative.begin());
      SurfacePoint p;
      if (k < rects.size()) {
        const Rect& r = rects[k];
        // Drawn in statements of their own, the second first as g++
        // evaluated the operands before (their order is unspecified).
        const double v = rng->Uniform();
        const double u = rng->Uniform();
        p.xyz = r.origin + u * r.a + v * r.b;
        p.normal = r.normal;
        p.tangent = r.tangent;
      } else {
        const CylinderSide& c = cylinders[k - rects.size()];
        const double theta = rng->Uniform(0.0, 2.0 * M_PI);
        const Eigen::Vector3d radial(std::cos(theta), std::sin(theta), 0.0);
        p.xyz = Eigen::Vector3d(c.center.x(), c.center.y(), 0.0) +
                c.radius * radial +
                Eigen::Vector3d(0, 0, rng->Uniform(c.z_min, c.z_max));
        p.normal = radial;
        p.tangent = Eigen::Vector3d::UnitZ();
      }
      points.push_back(p);
    }
    return points;
  }
};

// The facade motif of one period, in motif coordinates (u along the facade
// in [0, P], v depth into the building (negative: protruding towards the
// street), w height). Floors are 3 m high: a pillar at the period's left
// edge, one window per floor (a shop window on the ground floor) and
// balconies on odd floors.
class FacadeMotifGeometry {
 public:
  FacadeMotifGeometry(double period, double relief)
      : period_(period), relief_(relief) {
    pillar_width_ = std::min(0.6, 0.15 * period);
    const double center = pillar_width_ + 0.5 * (period - pillar_width_);
    const double width = std::min(2.4, 0.45 * (period - pillar_width_));
    window_left_ = center - 0.5 * width;
    window_right_ = center + 0.5 * width;
    balcony_left_ = std::max(pillar_width_ + 0.05, window_left_ - 0.3);
    balcony_right_ = std::min(period - 0.05, window_right_ + 0.3);
  }

  int NumFloors() const {
    return static_cast<int>(std::floor(kFacadeHeight / kFloorHeight + 1e-9));
  }
  // Window rows of floor f.
  double WindowBottom(int f) const {
    return f == 0 ? 0.4 : f * kFloorHeight + 1.0;
  }
  double WindowTop(int f) const {
    return f == 0 ? 2.6 : f * kFloorHeight + 2.4;
  }
  bool HasBalcony(int f) const { return f % 2 == 1; }

  // Depth of the surface seen from the front at (u, w).
  double FrontDepth(double u, double w) const {
    const int f = std::min(NumFloors() - 1,
                           static_cast<int>(std::floor(w / kFloorHeight)));
    if (HasBalcony(f) && u >= balcony_left_ && u <= balcony_right_ &&
        w - f * kFloorHeight < 1.0) {
      return -relief_;
    }
    if (u < pillar_width_) return -0.5 * relief_;
    if (u >= window_left_ && u <= window_right_ && w >= WindowBottom(f) &&
        w <= WindowTop(f)) {
      return 0.3 * relief_;
    }
    return 0.0;
  }

  // The faces perpendicular to the facade plane (empty when planar).
  SurfaceSet SideFaces() const {
    SurfaceSet set;
    if (relief_ <= 0.0) return set;
    const Eigen::Vector3d U = Eigen::Vector3d::UnitX();
    const Eigen::Vector3d V = Eigen::Vector3d::UnitY();
    const Eigen::Vector3d W = Eigen::Vector3d::UnitZ();
    auto add = [&](const Eigen::Vector3d& origin, const Eigen::Vector3d& a,
                   const Eigen::Vector3d& b, const Eigen::Vector3d& normal,
                   const Eigen::Vector3d& tangent) {
      Rect r;
      r.origin = origin;
      r.a = a;
      r.b = b;
      r.normal = normal;
      r.tangent = tangent;
      set.rects.push_back(r);
    };
    const double pillar = 0.5 * relief_;
    const double recess = 0.3 * relief_;
    // Pillar sides.
    add(Eigen::Vector3d(0, -pillar, 0), pillar * V, kFacadeHeight * W, -U, W);
    add(Eigen::Vector3d(pillar_width_, -pillar, 0), pillar * V,
        kFacadeHeight * W, U, W);
    const double window_width = window_right_ - window_left_;
    const double balcony_width = balcony_right_ - balcony_left_;
    for (int f = 0; f < NumFloors(); ++f) {
      // Window reveals: left, right, top and sill.
      const double bottom = WindowBottom(f), top = WindowTop(f);
      add(Eigen::Vector3d(window_left_, 0, bottom), recess * V,
          (top - bottom) * W, U, W);
      add(Eigen::Vector3d(window_right_, 0, bottom), recess * V,
          (top - bottom) * W, -U, W);
      add(Eigen::Vector3d(window_left_, 0, top), window_width * U, recess * V,
          -W, U);
      add(Eigen::Vector3d(window_left_, 0, bottom), window_width * U,
          recess * V, W, U);
      if (!HasBalcony(f)) continue;
      // Balcony parapet: sides and top.
      const double floor_z = f * kFloorHeight;
      add(Eigen::Vector3d(balcony_left_, -relief_, floor_z), relief_ * V,
          1.0 * W, -U, W);
      add(Eigen::Vector3d(balcony_right_, -relief_, floor_z), relief_ * V,
          1.0 * W, U, W);
      add(Eigen::Vector3d(balcony_left_, -relief_, floor_z + 1.0),
          balcony_width * U, relief_ * V, W, U);
    }
    return set;
  }

  double period() const { return period_; }

 private:
  double period_;
  double relief_;
  double pillar_width_ = 0.0;
  double window_left_ = 0.0, window_right_ = 0.0;
  double balcony_left_ = 0.0, balcony_right_ = 0.0;
};

// Points of one facade motif (density per m^2 of facade).
std::vector<SurfacePoint> MakeFacadeMotif(const FacadeMotifGeometry& geometry,
                                          double density, SynthRandom* rng) {
  const double period = geometry.period();
  const size_t num_front = static_cast<size_t>(
      std::max(1L, std::lround(density * period * kFacadeHeight)));
  std::vector<SurfacePoint> points;
  for (size_t i = 0; i < num_front; ++i) {
    SurfacePoint p;
    const double u = rng->Uniform(0.02, period - 0.02);
    const double w = rng->Uniform(0.1, kFacadeHeight - 0.1);
    p.xyz = Eigen::Vector3d(u, geometry.FrontDepth(u, w), w);
    p.normal = -Eigen::Vector3d::UnitY();
    p.tangent = Eigen::Vector3d::UnitX();
    points.push_back(p);
  }
  const SurfaceSet sides = geometry.SideFaces();
  const size_t num_sides =
      static_cast<size_t>(std::lround(density * sides.TotalArea()));
  for (const SurfacePoint& p : sides.Sample(num_sides, rng)) {
    points.push_back(p);
  }
  return points;
}

// Points of the corner motif: a pillar around a convex building corner, in
// the corner's frame (u along the face arriving at the corner, v into the
// building behind it, w up; the face leaving the corner lies in u = 0 and
// extends along +v).
std::vector<SurfacePoint> MakeCornerMotif(double relief, double density,
                                          SynthRandom* rng) {
  const double out = 0.5 * relief + 0.15;
  const double in = kCornerWidth;
  const Eigen::Vector3d U = Eigen::Vector3d::UnitX();
  const Eigen::Vector3d V = Eigen::Vector3d::UnitY();
  const Eigen::Vector3d W = Eigen::Vector3d::UnitZ();
  SurfaceSet set;
  auto add = [&](const Eigen::Vector3d& origin, const Eigen::Vector3d& a,
                 const Eigen::Vector3d& normal,
                 const Eigen::Vector3d& tangent) {
    Rect r;
    r.origin = origin;
    r.a = a;
    r.b = kFacadeHeight * W;
    r.normal = normal;
    r.tangent = tangent;
    set.rects.push_back(r);
  };
  add(Eigen::Vector3d(-in, -out, 0), (in + out) * U, -V, U);  // along face 1
  add(Eigen::Vector3d(out, -out, 0), (in + out) * V, U, W);   // along face 2
  add(Eigen::Vector3d(-in, -out, 0), out * V, -U, W);         // side, face 1
  add(Eigen::Vector3d(0, in, 0), out * U, V, W);              // side, face 2
  const size_t count =
      static_cast<size_t>(std::lround(density * set.TotalArea()));
  return set.Sample(std::max<size_t>(count, 1), rng);
}

// A facade of whole periods: u runs from `start` along `r`; `n` is the
// outward normal (towards the street), r = z x n.
struct Face {
  Eigen::Vector3d start = Eigen::Vector3d::Zero();
  Eigen::Vector3d r = Eigen::Vector3d::UnitX();
  Eigen::Vector3d n = -Eigen::Vector3d::UnitY();
  int num_periods = 0;
  // The face leaves / arrives at a corner pillar at u = 0 / at its end.
  bool corner_at_start = false;
  bool corner_at_end = false;
  // Extra ground beyond the end of the face (block corners).
  double ground_beyond_end = 0.0;
  // Depth of the ground strip in front of the face.
  double ground_depth = 0.0;
};

// A convex building corner where face `arriving` (direction r1, normal n1)
// meets the next face.
struct Corner {
  Eigen::Vector3d position = Eigen::Vector3d::Zero();
  Eigen::Vector3d r1 = Eigen::Vector3d::UnitX();
  Eigen::Vector3d n1 = -Eigen::Vector3d::UnitY();
};

Face MakeFace(const Eigen::Vector3d& start, const Eigen::Vector3d& n,
              int num_periods) {
  Face face;
  face.start = start;
  face.n = n.normalized();
  face.r = Eigen::Vector3d::UnitZ().cross(face.n);
  face.num_periods = num_periods;
  return face;
}

// world_from_motif of a frame with axes (r, -n, z) at `origin`.
Rigid3d FrameOf(const Eigen::Vector3d& origin, const Eigen::Vector3d& r,
                const Eigen::Vector3d& n) {
  Eigen::Matrix3d R;
  R.col(0) = r;
  R.col(1) = -n;
  R.col(2) = Eigen::Vector3d::UnitZ();
  return Rigid3d(Eigen::Quaterniond(R).normalized(), origin);
}

// A camera at `center` looking horizontally along `direction` (its z is
// ignored), pitched up by pitch_deg, with yaw, pitch and roll noise.
Rigid3d StreetCamera(const Eigen::Vector3d& center,
                     const Eigen::Vector3d& direction, double pitch_deg,
                     double rotation_jitter, SynthRandom* rng) {
  const double yaw = std::atan2(direction.y(), direction.x()) +
                     rng->Normal(rotation_jitter) * kDegToRad;
  const double pitch = (pitch_deg + rng->Normal(rotation_jitter)) * kDegToRad;
  const Eigen::Vector3d forward(std::cos(pitch) * std::cos(yaw),
                                std::cos(pitch) * std::sin(yaw),
                                std::sin(pitch));
  return LookAt(center, center + forward, rng->Normal(0.5 * rotation_jitter));
}

Eigen::Vector3d JitteredCenter(const Eigen::Vector3d& center, double sigma,
                               SynthRandom* rng) {
  // One draw per statement (argument order is unspecified), last
  // coordinate first as g++ evaluated the arguments when the families'
  // instances were measured.
  const double z = rng->Normal(0.5 * sigma);
  const double y = rng->Normal(sigma);
  const double x = rng->Normal(sigma);
  return center + Eigen::Vector3d(x, y, z);
}

// The distinct transforms between replicas of the same motif.
void BuildRelations(SymmetryGroup* symmetry) {
  const size_t n = symmetry->replica_frames.size();
  symmetry->relations.assign(1, Rigid3d());
  symmetry->relation_table.assign(n * n, -1);
  std::map<std::array<int64_t, 4>, int> ids;
  const int64_t half_turn = std::llround(M_PI * 1e5);
  std::vector<Rigid3d> inverses(n);
  for (size_t p = 0; p < n; ++p)
    inverses[p] = symmetry->replica_frames[p].Inverse();
  for (size_t p = 0; p < n; ++p) {
    for (size_t q = 0; q < n; ++q) {
      if (symmetry->replica_motifs[p] != symmetry->replica_motifs[q]) continue;
      int32_t& entry = symmetry->relation_table[p * n + q];
      if (p == q) {
        entry = 0;
        continue;
      }
      const Rigid3d g = symmetry->replica_frames[q] * inverses[p];
      // Every frame has z up: g is a rotation about z and a translation.
      const Eigen::Matrix3d R = g.rotation.toRotationMatrix();
      int64_t yaw = std::llround(std::atan2(R(1, 0), R(0, 0)) * 1e5);
      if (yaw == -half_turn) yaw = half_turn;
      const std::array<int64_t, 4> key = {
          yaw, std::llround(g.translation.x() * 1e4),
          std::llround(g.translation.y() * 1e4),
          std::llround(g.translation.z() * 1e4)};
      const auto [it, inserted] =
          ids.emplace(key, static_cast<int>(symmetry->relations.size()));
      if (inserted) symmetry->relations.push_back(g);
      entry = it->second;
    }
  }
}

// Builds a street-like family from its faces and corners: facade points,
// clutter, ground and the symmetry; the cameras are added by the caller.
class StreetBuilder {
 public:
  StreetBuilder(const SynthOptions& options, SynthSceneType type,
                const SynthFamilyOptions& family, SceneLayout* layout)
      : options_(options),
        type_(type),
        family_(family),
        layout_(layout),
        geometry_(family.period, family.relief_depth) {
    const double f = options.focal_length;
    const double d = family.facade_distance;
    density_ = kFacadePointsPerHeadOnImage * options.object_density * f * f /
               (static_cast<double>(options.image_width) *
                options.image_height * d * d);
  }

  void AddFace(const Face& face) { faces_.push_back(face); }
  void AddCorner(const Corner& corner) { corners_.push_back(corner); }
  // Ground rectangle beyond the face strips (a crossing).
  void AddGroundRect(const Rect& rect) { extra_ground_.push_back(rect); }

  void Build() {
    size_t num_copies = corners_.size();
    for (const Face& face : faces_) num_copies += face.num_periods;
    ThrowUnless(num_copies <= kMaxFamilyReplicas,
                StrCat("the scene needs ", num_copies,
                       " copies of its pattern (at most ", kMaxFamilyReplicas,
                       "): use fewer images, a smaller --camera_spacing or a "
                       "larger --period"));
    AddFacades();
    const size_t num_facade_points = layout_->points.size();
    AddClutter(num_facade_points);
    AddGround(num_facade_points);
    SymmetryGroup& symmetry = layout_->symmetry;
    if (family_.unique_pattern) {
      symmetry = SymmetryGroup();
    } else {
      symmetry.type = SymmetryGroup::Type::kReplicaFrames;
      symmetry.period = family_.period;
      BuildRelations(&symmetry);
    }
  }

 private:
  // Motif `m`'s points and first appearance id (made on first use).
  const std::vector<SurfacePoint>& MotifPoints(int m, bool corner,
                                               uint32_t* appearance) {
    auto it = motifs_.find(m);
    if (it == motifs_.end()) {
      SynthRandom rng(FamilySeed(options_, type_, kStreamMotifs + m));
      Motif motif;
      motif.points = corner
                         ? MakeCornerMotif(family_.relief_depth, density_, &rng)
                         : MakeFacadeMotif(geometry_, density_, &rng);
      motif.first_appearance = next_appearance_;
      next_appearance_ += static_cast<uint32_t>(motif.points.size());
      it = motifs_.emplace(m, std::move(motif)).first;
    }
    *appearance = it->second.first_appearance;
    return it->second.points;
  }

  // Places motif m with `frame`; `keep` filters motif points.
  template <typename Keep>
  void Place(int m, bool corner, const Rigid3d& frame, Keep&& keep) {
    uint32_t appearance = 0;
    const std::vector<SurfacePoint>& motif =
        MotifPoints(m, corner, &appearance);
    int32_t replica = 0;
    if (!family_.unique_pattern) {
      replica = static_cast<int32_t>(layout_->symmetry.replica_frames.size());
      layout_->symmetry.replica_frames.push_back(frame);
      layout_->symmetry.replica_motifs.push_back(m);
    }
    for (size_t i = 0; i < motif.size(); ++i) {
      if (!keep(motif[i].xyz)) continue;
      ScenePoint p;
      p.on_object = true;
      p.xyz = frame * motif[i].xyz;
      p.normal = frame.rotation * motif[i].normal;
      p.tangent = frame.rotation * motif[i].tangent;
      p.replica = replica;
      p.appearance = appearance + static_cast<uint32_t>(i);
      layout_->points.push_back(p);
    }
  }

  void AddFacades() {
    const double period = family_.period;
    const int block_periods =
        family_.block_length > 0
            ? std::max(1, static_cast<int>(
                              std::lround(family_.block_length / period)))
            : 0;
    int global_period = 0;
    int next_unique = 0;
    for (const Face& face : faces_) {
      const double length = face.num_periods * period;
      for (int j = 0; j < face.num_periods; ++j, ++global_period) {
        int m = 0;
        if (family_.unique_pattern) {
          m = next_unique++;
        } else if (block_periods > 0) {
          m = global_period / block_periods;
        }
        const double u0 = j * period;
        // Corner pillars hide the facade behind them.
        auto keep = [&](const Eigen::Vector3d& x) {
          const double u = u0 + x.x();
          if (face.corner_at_start && u < kCornerWidth) return false;
          if (face.corner_at_end && u > length - kCornerWidth) return false;
          return true;
        };
        Place(m, false, FrameOf(face.start + u0 * face.r, face.r, face.n),
              keep);
      }
    }
    // Corner motifs after every facade motif (ids far above them).
    const int corner_base = 1 << 24;
    for (size_t c = 0; c < corners_.size(); ++c) {
      const int m = family_.unique_pattern ? corner_base + static_cast<int>(c)
                                           : corner_base;
      Place(m, true,
            FrameOf(corners_[c].position, corners_[c].r1, corners_[c].n1),
            [](const Eigen::Vector3d&) { return true; });
    }
  }

  void AddClutter(size_t num_facade_points) {
    SynthRandom rng(FamilySeed(options_, type_, kStreamClutter));
    const double distance = family_.facade_distance;
    SurfaceSet surfaces;
    for (const Face& face : faces_) {
      const double length = face.num_periods * family_.period;
      const int count = static_cast<int>(std::lround(length / kClutterSpacing));
      for (int k = 0; k < count; ++k) {
        const double along = rng.Uniform(0.5, length - 0.5);
        const double kind = rng.Uniform();
        // Half depth of each kind across the street.
        double half_depth = kind < 0.3    ? 0.12
                            : kind < 0.5  ? 1.0
                            : kind < 0.85 ? 0.9
                                          : 0.8;
        double lo = half_depth + 0.3;
        double hi = kClutterZone * distance - half_depth;
        const bool fits = lo <= hi;
        if (!fits) {
          half_depth = 0.12;
          lo = half_depth + 0.3;
          hi = kClutterZone * distance - half_depth;
        }
        const double depth = rng.Uniform(lo, std::max(lo, hi));
        const Eigen::Vector3d base =
            face.start + along * face.r + depth * face.n;
        const Eigen::Vector2d center = base.head<2>();
        if (!fits || kind < 0.3) {
          AddCylinder(center, 0.12, 0.0, 4.5, &surfaces);  // pole
        } else if (kind < 0.5) {
          AddCylinder(center, 0.25, 0.0, 2.5, &surfaces);  // tree trunk
          AddCylinder(center, 1.0, 2.5, 5.0, &surfaces);   // and crown
        } else if (kind < 0.85) {
          const double yaw =
              std::atan2(face.r.y(), face.r.x()) + rng.Normal(2.0) * kDegToRad;
          AddBox(center, Eigen::Vector2d(2.2, 0.9), yaw, 1.5,
                 &surfaces);  // car
        } else {
          AddBox(center, Eigen::Vector2d(0.8, 0.8), rng.Uniform(0.0, M_PI), 2.6,
                 &surfaces);  // kiosk
        }
      }
    }
    const size_t count = static_cast<size_t>(
        std::lround(family_.clutter_density * num_facade_points));
    for (const SurfacePoint& s : surfaces.Sample(count, &rng)) {
      ScenePoint p;
      p.xyz = s.xyz;
      p.normal = s.normal;
      p.tangent = s.tangent;
      p.clutter = true;
      p.appearance = next_appearance_++;
      layout_->points.push_back(p);
    }
  }

  void AddCylinder(const Eigen::Vector2d& center, double radius, double z_min,
                   double z_max, SurfaceSet* surfaces) {
    CylinderOccluder occluder;
    occluder.center = center;
    occluder.radius = radius;
    occluder.z_min = z_min;
    occluder.z_max = z_max;
    layout_->occluders.push_back(occluder);
    CylinderSide side;
    side.center = center;
    side.radius = radius;
    side.z_min = z_min;
    side.z_max = z_max;
    surfaces->cylinders.push_back(side);
  }

  void AddBox(const Eigen::Vector2d& center, const Eigen::Vector2d& half,
              double yaw, double height, SurfaceSet* surfaces) {
    BoxOccluder box;
    box.center = center;
    box.half_size = half;
    box.yaw = yaw;
    box.z_min = 0.0;
    box.z_max = height;
    layout_->boxes.push_back(box);
    const Eigen::Vector3d ex(std::cos(yaw), std::sin(yaw), 0.0);
    const Eigen::Vector3d ey(-std::sin(yaw), std::cos(yaw), 0.0);
    const Eigen::Vector3d ez = Eigen::Vector3d::UnitZ();
    const Eigen::Vector3d c(center.x(), center.y(), 0.0);
    auto side = [&](const Eigen::Vector3d& normal, const Eigen::Vector3d& along,
                    double half_normal, double half_along) {
      Rect r;
      r.origin = c + half_normal * normal - half_along * along;
      r.a = 2.0 * half_along * along;
      r.b = height * ez;
      r.normal = normal;
      r.tangent = ez;
      surfaces->rects.push_back(r);
    };
    side(ex, ey, half.x(), half.y());
    side(-ex, ey, half.x(), half.y());
    side(ey, ex, half.y(), half.x());
    side(-ey, ex, half.y(), half.x());
    Rect top;
    top.origin = c - half.x() * ex - half.y() * ey + height * ez;
    top.a = 2.0 * half.x() * ex;
    top.b = 2.0 * half.y() * ey;
    top.normal = ez;
    top.tangent = ex;
    surfaces->rects.push_back(top);
  }

  void AddGround(size_t num_facade_points) {
    if (family_.ground_density <= 0.0) return;
    SynthRandom rng(FamilySeed(options_, type_, kStreamGround));
    SurfaceSet ground;
    for (const Face& face : faces_) {
      Rect r;
      r.origin = face.start;
      r.a =
          (face.num_periods * family_.period + face.ground_beyond_end) * face.r;
      r.b = face.ground_depth * face.n;
      ground.rects.push_back(r);
    }
    for (const Rect& r : extra_ground_) ground.rects.push_back(r);
    for (Rect& r : ground.rects) {
      r.normal = Eigen::Vector3d::UnitZ();
      r.tangent = Eigen::Vector3d::UnitX();
    }
    const size_t count = static_cast<size_t>(
        std::lround(family_.ground_density * num_facade_points));
    for (const SurfacePoint& s : ground.Sample(count, &rng)) {
      ScenePoint p;
      p.xyz = s.xyz;
      p.normal = s.normal;
      p.tangent = s.tangent;
      p.appearance = next_appearance_++;
      layout_->points.push_back(p);
    }
  }

  struct Motif {
    std::vector<SurfacePoint> points;
    uint32_t first_appearance = 0;
  };

  const SynthOptions& options_;
  SynthSceneType type_;
  const SynthFamilyOptions& family_;
  SceneLayout* layout_;
  FacadeMotifGeometry geometry_;
  double density_ = 0.0;
  std::vector<Face> faces_;
  std::vector<Corner> corners_;
  std::vector<Rect> extra_ground_;
  std::map<int, Motif> motifs_;
  uint32_t next_appearance_ = 0;
};

// Metres of facade an image sees on each side of its viewing direction,
// plus a period: the facades extend this far beyond the camera path.
double FacadeMargin(const SynthOptions& options,
                    const SynthFamilyOptions& family) {
  const double half_width = 0.5 * options.image_width / options.focal_length;
  return 1.5 * family.facade_distance * half_width + family.period + 1.0;
}

int WholePeriods(double length, double period, int at_least) {
  return std::max(at_least,
                  static_cast<int>(std::ceil(length / period - 1e-9)));
}

void BuildFacadeStreet(const SynthOptions& options, SynthFamilyOptions* family,
                       SceneLayout* layout) {
  const int n = options.num_images;
  const double spacing = family->camera_spacing;
  const double distance = family->facade_distance;
  const double margin = FacadeMargin(options, *family);
  const int num_periods =
      WholePeriods((n - 1) * spacing + 2.0 * margin, family->period, 2);
  StreetBuilder builder(options, SynthSceneType::kFacadeStreet, *family,
                        layout);
  Face face = MakeFace(Eigen::Vector3d(-margin, distance, 0.0),
                       -Eigen::Vector3d::UnitY(), num_periods);
  face.ground_depth = distance + 3.0;
  builder.AddFace(face);
  builder.Build();

  SynthRandom rng(
      FamilySeed(options, SynthSceneType::kFacadeStreet, kStreamCameras));
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d center =
        JitteredCenter(Eigen::Vector3d(i * spacing, 0.0, kCameraHeight),
                       family->position_jitter, &rng);
    layout->cams_from_world.push_back(
        StreetCamera(center, Eigen::Vector3d::UnitY(), kCameraPitchDeg,
                     family->rotation_jitter, &rng));
  }
  layout->max_view_distance = 3.0 * distance + 10.0;
  layout->detection_reference_distance = distance;
  layout->pair_radius = 2.0 * margin;
}

void BuildBlockLoop(const SynthOptions& options, SynthFamilyOptions* family,
                    SceneLayout* layout) {
  const int n = options.num_images;
  const double period = family->period;
  const double distance = family->facade_distance;
  const double arcs = 2.0 * M_PI * distance;
  // Sides (long, short) from the loop length n * spacing.
  const double sum = std::max(0.0, 0.5 * (n * family->camera_spacing - arcs));
  const double long_side = sum / (1.0 + family->block_aspect);
  const int long_periods =
      std::max(1, static_cast<int>(std::lround(long_side / period)));
  const int short_periods = std::max(
      1,
      static_cast<int>(std::lround(family->block_aspect * long_side / period)));
  const double lx = long_periods * period;
  const double ly = short_periods * period;
  const double loop = 2.0 * (lx + ly) + arcs;
  family->camera_spacing = loop / n;

  // Faces counter-clockwise seen from above, each facing outwards.
  const Eigen::Vector3d starts[4] = {Eigen::Vector3d(-0.5 * lx, -0.5 * ly, 0),
                                     Eigen::Vector3d(0.5 * lx, -0.5 * ly, 0),
                                     Eigen::Vector3d(0.5 * lx, 0.5 * ly, 0),
                                     Eigen::Vector3d(-0.5 * lx, 0.5 * ly, 0)};
  const Eigen::Vector3d normals[4] = {
      -Eigen::Vector3d::UnitY(), Eigen::Vector3d::UnitX(),
      Eigen::Vector3d::UnitY(), -Eigen::Vector3d::UnitX()};
  const int periods[4] = {long_periods, short_periods, long_periods,
                          short_periods};
  StreetBuilder builder(options, SynthSceneType::kBlockLoop, *family, layout);
  std::vector<Face> faces;
  for (int k = 0; k < 4; ++k) {
    Face face = MakeFace(starts[k], normals[k], periods[k]);
    face.corner_at_start = face.corner_at_end = true;
    face.ground_depth = distance + 2.0;
    face.ground_beyond_end = distance + 2.0;
    faces.push_back(face);
    builder.AddFace(face);
  }
  for (int k = 0; k < 4; ++k) {
    Corner corner;
    corner.position = starts[(k + 1) % 4];
    corner.r1 = faces[k].r;
    corner.n1 = faces[k].n;
    builder.AddCorner(corner);
  }
  builder.Build();

  // The loop: along face k at `distance`, then a quarter circle around the
  // corner at its end.
  SynthRandom rng(
      FamilySeed(options, SynthSceneType::kBlockLoop, kStreamCameras));
  for (int i = 0; i < n; ++i) {
    double t = i * family->camera_spacing;
    Eigen::Vector3d position, look;
    for (int k = 0; k < 4; ++k) {
      const double length = faces[k].num_periods * period;
      if (t < length) {
        position = faces[k].start + t * faces[k].r + distance * faces[k].n;
        look = -faces[k].n;
        break;
      }
      t -= length;
      const double arc = 0.5 * M_PI * distance;
      if (t < arc || k == 3) {
        const double phi = std::atan2(faces[k].n.y(), faces[k].n.x()) +
                           std::min(t, arc) / distance;
        const Eigen::Vector3d radial(std::cos(phi), std::sin(phi), 0.0);
        position = starts[(k + 1) % 4] + distance * radial;
        look = -radial;
        break;
      }
      t -= arc;
    }
    const Eigen::Vector3d center =
        JitteredCenter(position + Eigen::Vector3d(0, 0, kCameraHeight),
                       family->position_jitter, &rng);
    layout->cams_from_world.push_back(StreetCamera(
        center, look, kCameraPitchDeg, family->rotation_jitter, &rng));
  }
  layout->max_view_distance = 3.0 * distance + 10.0;
  layout->detection_reference_distance = distance;
  layout->pair_radius = 2.0 * FacadeMargin(options, *family);
}

void BuildCrossingStreets(const SynthOptions& options,
                          SynthFamilyOptions* family, SceneLayout* layout) {
  const int n = options.num_images;
  const int num_a = (n + 1) / 2;
  const int num_b = n - num_a;
  const double spacing = family->camera_spacing;
  const double distance = family->facade_distance;
  const double period = family->period;
  layout->max_view_distance = std::max(30.0, 5.0 * distance);
  layout->detection_reference_distance = distance;
  // Facades reach as far as an image at the end of a street sees.
  const double half_path = 0.5 * (std::max(num_a, num_b) - 1) * spacing;
  const double reach = std::min(layout->max_view_distance,
                                distance * std::tan(80.0 * kDegToRad));
  const int num_periods =
      WholePeriods(half_path + reach + period - distance, period, 2);
  const double end = distance + num_periods * period;

  StreetBuilder builder(options, SynthSceneType::kCrossingStreets, *family,
                        layout);
  // Building in quadrant (sx, sy): its face on street A (y = sy D) and on
  // street B (x = sx D); the face whose direction points at the corner
  // arrives there.
  for (int quadrant = 0; quadrant < 4; ++quadrant) {
    const double sx = quadrant == 0 || quadrant == 3 ? 1.0 : -1.0;
    const double sy = quadrant < 2 ? 1.0 : -1.0;
    const Eigen::Vector3d corner_position(sx * distance, sy * distance, 0.0);
    const Eigen::Vector3d normal_a(0.0, -sy, 0.0);
    const Eigen::Vector3d normal_b(-sx, 0.0, 0.0);
    const Eigen::Vector3d r_a = Eigen::Vector3d::UnitZ().cross(normal_a);
    const bool a_leaves = r_a.x() * sx > 0;  // A's face starts at the corner
    Face face_a =
        MakeFace(a_leaves ? corner_position
                          : Eigen::Vector3d(sx * end, sy * distance, 0.0),
                 normal_a, num_periods);
    Face face_b =
        MakeFace(a_leaves ? Eigen::Vector3d(sx * distance, sy * end, 0.0)
                          : corner_position,
                 normal_b, num_periods);
    face_a.corner_at_start = a_leaves;
    face_a.corner_at_end = !a_leaves;
    face_b.corner_at_start = !a_leaves;
    face_b.corner_at_end = a_leaves;
    face_a.ground_depth = face_b.ground_depth = distance;
    builder.AddFace(face_a);
    builder.AddFace(face_b);
    const Face& arriving = a_leaves ? face_b : face_a;
    Corner corner;
    corner.position = corner_position;
    corner.r1 = arriving.r;
    corner.n1 = arriving.n;
    builder.AddCorner(corner);
  }
  Rect crossing;
  crossing.origin = Eigen::Vector3d(-distance, -distance, 0.0);
  crossing.a = 2.0 * distance * Eigen::Vector3d::UnitX();
  crossing.b = 2.0 * distance * Eigen::Vector3d::UnitY();
  builder.AddGroundRect(crossing);
  builder.Build();

  SynthRandom rng(
      FamilySeed(options, SynthSceneType::kCrossingStreets, kStreamCameras));
  const double angle = family->view_angle * kDegToRad;
  for (int i = 0; i < n; ++i) {
    const bool on_a = i < num_a;
    const int k = on_a ? i : i - num_a;
    const double along = (k - 0.5 * ((on_a ? num_a : num_b) - 1)) * spacing;
    const Eigen::Vector3d ahead =
        on_a ? Eigen::Vector3d::UnitX() : Eigen::Vector3d::UnitY();
    const Eigen::Vector3d left = Eigen::Vector3d::UnitZ().cross(ahead);
    const double side = on_a ? 1.0 : -1.0;
    const Eigen::Vector3d look =
        std::cos(angle) * ahead + side * std::sin(angle) * left;
    const Eigen::Vector3d center =
        JitteredCenter(along * ahead + Eigen::Vector3d(0, 0, kCameraHeight),
                       family->position_jitter, &rng);
    layout->cams_from_world.push_back(StreetCamera(
        center, look, kCameraPitchDeg, family->rotation_jitter, &rng));
  }
  layout->pair_radius = 2.0 * reach;
}

void BuildSymmetricObject(const SynthOptions& options,
                          const SynthFamilyOptions& family,
                          SceneLayout* layout) {
  const int fold = family.symmetry_order;
  const bool repeated = !family.unique_pattern;
  SynthRandom rng(
      FamilySeed(options, SynthSceneType::kSymmetricObject, kStreamObject));
  uint32_t next_appearance = 0;

  // One sector of the print, replicated `fold` times around the z axis.
  const int per_sector = std::max(
      1, static_cast<int>(std::lround(kObjectPoints * options.object_density)) /
             fold);
  const double sector = 2.0 * M_PI / fold;
  const double side_area = 2.0 * M_PI * kObjectRadius * kObjectHeight;
  const double top_area = M_PI * kObjectRadius * kObjectRadius;
  const double side_fraction = side_area / (side_area + top_area);
  std::vector<SurfacePoint> motif(per_sector);
  for (SurfacePoint& p : motif) {
    const double theta = rng.Uniform(0.0, sector);
    const Eigen::Vector3d radial(std::cos(theta), std::sin(theta), 0.0);
    if (rng.Uniform() < side_fraction) {
      p.xyz = kObjectRadius * radial +
              Eigen::Vector3d(0, 0, rng.Uniform(0.05, kObjectHeight - 0.05));
      p.normal = radial;
      p.tangent = Eigen::Vector3d::UnitZ();
    } else {
      p.xyz = 0.97 * kObjectRadius * std::sqrt(rng.Uniform()) * radial +
              Eigen::Vector3d(0, 0, kObjectHeight);
      p.normal = Eigen::Vector3d::UnitZ();
      p.tangent = radial;
    }
  }
  const uint32_t motif_base = next_appearance;
  if (repeated) next_appearance += per_sector;
  for (int k = 0; k < fold; ++k) {
    const Eigen::Matrix3d R =
        Eigen::AngleAxisd(k * sector, Eigen::Vector3d::UnitZ())
            .toRotationMatrix();
    for (int i = 0; i < per_sector; ++i) {
      ScenePoint p;
      p.on_object = true;
      p.xyz = R * motif[i].xyz;
      p.normal = R * motif[i].normal;
      p.tangent = R * motif[i].tangent;
      p.replica = repeated ? k : 0;
      p.appearance = repeated ? motif_base + i : next_appearance++;
      layout->points.push_back(p);
    }
  }

  // Unique background: half on the surrounding wall, half on the ground.
  const double wall_radius = std::max(8.0, family.ring_radius + 3.0);
  const size_t num_object = static_cast<size_t>(per_sector) * fold;
  const size_t num_background =
      static_cast<size_t>(std::lround(family.clutter_density * num_object));
  for (size_t i = 0; i < num_background; ++i) {
    ScenePoint p;
    const double theta = rng.Uniform(0.0, 2.0 * M_PI);
    const Eigen::Vector3d radial(std::cos(theta), std::sin(theta), 0.0);
    if (i % 2 == 0) {
      p.xyz = wall_radius * radial +
              Eigen::Vector3d(0, 0, rng.Uniform(0.05, kWallHeight - 0.05));
      p.normal = -radial;
      p.tangent = Eigen::Vector3d::UnitZ();
    } else {
      const double r0 = 1.05 * kObjectRadius;
      const double rho =
          std::sqrt(r0 * r0 + rng.Uniform() *
                                  (wall_radius * wall_radius - r0 * r0) * 0.96);
      p.xyz = rho * radial;
      p.normal = Eigen::Vector3d::UnitZ();
      p.tangent = Eigen::Vector3d::UnitX();
    }
    p.clutter = true;
    p.appearance = next_appearance++;
    layout->points.push_back(p);
  }

  // A ring of cameras looking at the object.
  SynthRandom camera_rng(
      FamilySeed(options, SynthSceneType::kSymmetricObject, kStreamCameras));
  const int n = options.num_images;
  for (int i = 0; i < n; ++i) {
    const double phi = 2.0 * M_PI * i / n;
    const Eigen::Vector3d center = JitteredCenter(
        Eigen::Vector3d(family.ring_radius * std::cos(phi),
                        family.ring_radius * std::sin(phi), kRingHeight),
        family.position_jitter, &camera_rng);
    const Eigen::Vector3d to_target =
        Eigen::Vector3d(0, 0, kRingLookAtHeight) - center;
    const double pitch_deg =
        std::atan2(to_target.z(), to_target.head<2>().norm()) / kDegToRad;
    layout->cams_from_world.push_back(StreetCamera(
        center, to_target, pitch_deg, family.rotation_jitter, &camera_rng));
  }

  layout->symmetry.type =
      repeated ? SymmetryGroup::Type::kRotationZ : SymmetryGroup::Type::kNone;
  layout->symmetry.order = repeated ? fold : 1;
  CylinderOccluder occluder;
  occluder.radius = kObjectRadius;
  occluder.z_min = 0.0;
  occluder.z_max = kObjectHeight;
  layout->occluders.push_back(occluder);
  layout->max_view_distance = 2.0 * wall_radius;
  layout->pair_radius = 2.0 * family.ring_radius;
}

}  // namespace

SynthFamilyOptions ResolveFamilyOptions(const SynthOptions& options) {
  options.Check();
  SynthFamilyOptions family = options.family;
  if (!family.randomize) return family;
  family.randomize = false;
  const SynthSceneType type = ParseSynthSceneType(options.scene);
  SynthRandom rng(FamilySeed(options, type, kStreamParameters));
  // Every value is drawn whatever the family, in a fixed order, and rounded
  // so that it can be passed back as a flag.
  family.period = RoundTo(rng.Uniform(2.0, 8.0), 2);
  const double spacing_min = std::max(0.5, family.period / 10.0);
  const double spacing_max = std::min(2.0, family.period / 2.0);
  family.camera_spacing =
      std::clamp(RoundTo(rng.Uniform(spacing_min, spacing_max), 2),
                 spacing_min, spacing_max);
  family.relief_depth = RoundTo(rng.Uniform(0.0, 1.5), 2);
  family.clutter_density = RoundTo(rng.Uniform(0.1, 0.5), 2);
  family.facade_distance = RoundTo(rng.Uniform(5.0, 15.0), 2);
  family.position_jitter = RoundTo(rng.Uniform(0.0, 0.2), 3);
  family.rotation_jitter = RoundTo(rng.Uniform(0.0, 4.0), 2);
  family.block_aspect = RoundTo(rng.Uniform(0.5, 1.0), 2);
  family.view_angle = RoundTo(rng.Uniform(40.0, 60.0), 1);
  family.symmetry_order = 2 + static_cast<int>(rng.UniformInt(3));
  family.ring_radius = RoundTo(rng.Uniform(3.0, 6.0), 2);
  family.Check();
  return family;
}

void BuildFamilyLayout(const SynthOptions& options, SynthSceneType type,
                       SceneLayout* layout) {
  ThrowUnless(IsSynthFamily(type),
              StrCat(SynthSceneTypeName(type), " is not a scene family"));
  SynthFamilyOptions family = ResolveFamilyOptions(options);
  layout->family = true;
  switch (type) {
    case SynthSceneType::kFacadeStreet:
      BuildFacadeStreet(options, &family, layout);
      break;
    case SynthSceneType::kBlockLoop:
      BuildBlockLoop(options, &family, layout);
      break;
    case SynthSceneType::kCrossingStreets:
      BuildCrossingStreets(options, &family, layout);
      break;
    default:
      BuildSymmetricObject(options, family, layout);
      break;
  }
  layout->family_options = family;
}

}  // namespace hisfm
