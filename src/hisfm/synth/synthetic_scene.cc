#include "hisfm/synth/synthetic_scene.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>
#include <unordered_map>

#include "hisfm/synth/synth_random.h"
#include "hisfm/util/error.h"
#include "hisfm/util/parallel.h"

namespace hisfm {
namespace {

// Family scenes: per-view variation of a point's detectability (see
// GenerateImage).
constexpr double kDetectionJitter = 0.2;

// Cosine of the largest angle between a point's normal and the ray to a
// camera that still shows the point (80 degrees).
constexpr double kMinFacingCosine = 0.17364817766693041;
constexpr double kMinDepth = 0.1;
// Family scenes: the occlusion test of a point stops this far (metres) short
// of it, so that the surface the point lies on does not hide it.
constexpr double kSurfaceOffset = 0.02;

// Whether a solid's bounding sphere may meet the viewing cone (apex
// `center`, unit `axis`, half angle `half_angle`) within `max_distance`.
bool SphereMeetsCone(const Eigen::Vector3d& sphere_center, double radius,
                     const Eigen::Vector3d& center, const Eigen::Vector3d& axis,
                     double half_angle, double max_distance) {
  const Eigen::Vector3d v = sphere_center - center;
  const double dist = v.norm();
  if (dist - radius > max_distance) return false;
  if (dist <= radius) return true;
  const double angle = std::acos(std::clamp(v.dot(axis) / dist, -1.0, 1.0));
  return angle <= half_angle + std::asin(radius / dist);
}

// The occluders of a family scene that may hide points from one camera.
struct NearbyOccluders {
  std::vector<const CylinderOccluder*> cylinders;
  std::vector<const BoxOccluder*> boxes;

  NearbyOccluders(const SceneLayout& layout, const Eigen::Vector3d& center,
                  const Eigen::Vector3d& axis, double half_angle) {
    const double range = layout.max_view_distance;
    for (const CylinderOccluder& c : layout.occluders) {
      const double h = 0.5 * (c.z_max - c.z_min);
      const Eigen::Vector3d mid(c.center.x(), c.center.y(), c.z_min + h);
      if (SphereMeetsCone(mid, std::hypot(c.radius, h), center, axis,
                          half_angle, range)) {
        cylinders.push_back(&c);
      }
    }
    for (const BoxOccluder& b : layout.boxes) {
      const double h = 0.5 * (b.z_max - b.z_min);
      const Eigen::Vector3d mid(b.center.x(), b.center.y(), b.z_min + h);
      if (SphereMeetsCone(mid, std::hypot(b.half_size.norm(), h), center,
                          axis, half_angle, range)) {
        boxes.push_back(&b);
      }
    }
  }

  // True if a solid lies between the camera centre and the point `xyz`.
  bool Hide(const Eigen::Vector3d& center, const Eigen::Vector3d& xyz) const {
    const Eigen::Vector3d to_cam = center - xyz;
    const Eigen::Vector3d end = xyz + (kSurfaceOffset / to_cam.norm()) * to_cam;
    for (const CylinderOccluder* c : cylinders) {
      if (c->Occludes(center, end)) return true;
    }
    for (const BoxOccluder* b : boxes) {
      if (b->Occludes(center, end)) return true;
    }
    return false;
  }
};

// COLMAP's camera model ids.
int ModelIdOfName(const std::string& name) {
  if (name == "SIMPLE_PINHOLE") return 0;
  if (name == "PINHOLE") return 1;
  if (name == "SIMPLE_RADIAL") return 2;
  throw Error(StrCat("unsupported camera model ", name));
}

// Points bucketed in a uniform grid over x and y, for frustum culling.
class PointGrid {
 public:
  PointGrid(const std::vector<ScenePoint>& points, double cell_size)
      : cell_size_(cell_size) {
    for (uint32_t i = 0; i < points.size(); ++i) {
      const Eigen::Vector3d& x = points[i].xyz;
      Cell& cell = cells_[Key(CellCoord(x.x()), CellCoord(x.y()))];
      if (cell.points.empty()) {
        cell.ix = CellCoord(x.x());
        cell.iy = CellCoord(x.y());
        cell.z_min = cell.z_max = x.z();
      }
      cell.points.push_back(i);
      cell.z_min = std::min(cell.z_min, x.z());
      cell.z_max = std::max(cell.z_max, x.z());
    }
    // Deterministic iteration order.
    for (auto& [key, cell] : cells_) ordered_.push_back(&cell);
    std::sort(ordered_.begin(), ordered_.end(), [](const Cell* a, const Cell* b) {
      return a->ix != b->ix ? a->ix < b->ix : a->iy < b->iy;
    });
  }

  /// Calls fn(point index) for the points of every cell that may intersect
  /// the viewing cone (apex `center`, unit `axis`, half angle `half_angle`)
  /// within `max_distance`.
  template <typename Fn>
  void ForEachInCone(const Eigen::Vector3d& center, const Eigen::Vector3d& axis,
                     double half_angle, double max_distance, Fn&& fn) const {
    const double half_diag_xy = cell_size_ * std::sqrt(0.5);
    for (const Cell* cell : ordered_) {
      const Eigen::Vector3d mid((cell->ix + 0.5) * cell_size_,
                                (cell->iy + 0.5) * cell_size_,
                                0.5 * (cell->z_min + cell->z_max));
      const double dz = 0.5 * (cell->z_max - cell->z_min);
      const double radius = std::sqrt(half_diag_xy * half_diag_xy + dz * dz);
      const Eigen::Vector3d v = mid - center;
      const double dist = v.norm();
      if (dist - radius > max_distance) continue;
      if (dist > radius) {
        const double angle = std::acos(std::clamp(v.dot(axis) / dist, -1.0, 1.0));
        if (angle > half_angle + std::asin(radius / dist)) continue;
      }
      for (uint32_t i : cell->points) fn(i);
    }
  }

 private:
  struct Cell {
    int64_t ix = 0, iy = 0;
    double z_min = 0, z_max = 0;
    std::vector<uint32_t> points;
  };
  int64_t CellCoord(double v) const {
    return static_cast<int64_t>(std::floor(v / cell_size_));
  }
  static uint64_t Key(int64_t ix, int64_t iy) {
    return (static_cast<uint64_t>(ix) << 32) ^ static_cast<uint32_t>(iy);
  }

  double cell_size_;
  std::unordered_map<uint64_t, Cell> cells_;
  std::vector<const Cell*> ordered_;
};

void GenerateImage(const SyntheticScene& scene, const PointGrid& grid,
                   size_t index, SynthImage* image) {
  const SynthOptions& options = scene.options;
  const SceneLayout& layout = scene.layout;
  image->image_id = static_cast<ImageId>(index + 1);
  image->name = SynthImageName(index);
  image->cam_from_world = layout.cams_from_world[index];
  SynthRandom rng(DeriveSeed(options.seed, 3, index));

  const Eigen::Matrix3d R = image->cam_from_world.rotation.toRotationMatrix();
  const Eigen::Vector3d& t = image->cam_from_world.translation;
  const Eigen::Vector3d center = -R.transpose() * t;
  const Eigen::Vector3d axis = R.row(2).transpose();
  const double w = options.image_width, h = options.image_height;
  const double f = options.focal_length;
  const double half_angle =
      std::atan(0.5 * std::sqrt(w * w + h * h) / f);
  const std::optional<NearbyOccluders> nearby =
      layout.family ? std::optional<NearbyOccluders>(
                          std::in_place, layout, center, axis, half_angle)
                    : std::nullopt;
  const double descriptor_noise =
      layout.family ? layout.family_options.descriptor_noise * M_PI / 180.0
                    : 0.0;

  grid.ForEachInCone(center, axis, half_angle, layout.max_view_distance,
                     [&](uint32_t pi) {
    const ScenePoint& p = layout.points[pi];
    const Eigen::Vector3d xc = R * p.xyz + t;
    if (xc.z() < kMinDepth) return;
    const Eigen::Vector3d to_cam = center - p.xyz;
    const double dist = to_cam.norm();
    if (dist > layout.max_view_distance) return;
    if (p.normal.dot(to_cam) < kMinFacingCosine * dist) return;
    const double u = f * xc.x() / xc.z() + 0.5 * w;
    const double v = f * xc.y() / xc.z() + 0.5 * h;
    if (u < 1.0 || u > w - 1.0 || v < 1.0 || v > h - 1.0) return;
    if (nearby) {
      if (nearby->Hide(center, p.xyz)) return;
    } else if (!p.on_object) {
      for (const CylinderOccluder& occluder : layout.occluders) {
        if (occluder.Occludes(center, p.xyz)) return;
      }
    }
    double detection = options.detection_probability;
    if (layout.detection_reference_distance > 0.0) {
      const double ref = layout.detection_reference_distance;
      detection *= std::min(
          1.0, ref * ref * p.normal.dot(to_cam) / (dist * dist * dist));
    }
    if (layout.family) {
      // A point's detectability persists from view to view (its texture
      // and contrast), with a little per-view variation: a detector that
      // finds a corner in one photo finds it in the next, unless the view
      // makes it too small or too oblique.
      const double strength =
          SynthRandom(DeriveSeed(options.seed, 11, pi)).Uniform();
      if (strength + kDetectionJitter * (rng.Uniform() - 0.5) >= detection) {
        return;
      }
    } else if (!rng.Bernoulli(detection)) {
      return;
    }
    SynthFeature feature;
    feature.point_index = pi;
    const double nu = rng.Normal(options.keypoint_noise);
    const double nv = rng.Normal(options.keypoint_noise);
    feature.xy = Eigen::Vector2f(static_cast<float>(std::clamp(u + nu, 0.0, w)),
                                 static_cast<float>(std::clamp(v + nv, 0.0, h)));
    const Eigen::Vector3d d = to_cam / dist;
    const Eigen::Vector3d bitangent = p.normal.cross(p.tangent);
    Eigen::Vector3d local(d.dot(p.tangent), d.dot(bitangent), d.dot(p.normal));
    if (descriptor_noise > 0.0) {
      // One draw per statement, last coordinate first (as g++ evaluated
      // the arguments before; argument order is unspecified).
      const double nz = rng.Normal(descriptor_noise);
      const double ny = rng.Normal(descriptor_noise);
      const double nx = rng.Normal(descriptor_noise);
      local += Eigen::Vector3d(nx, ny, nz);
      local.normalize();
    }
    feature.local_view = local.cast<float>();
    feature.distance = static_cast<float>(dist);
    image->features.push_back(feature);
  });

  const size_t num_distractors = static_cast<size_t>(
      std::floor(options.distractor_ratio * image->features.size() +
                 rng.Uniform()));
  for (size_t k = 0; k < num_distractors; ++k) {
    SynthFeature feature;
    // One draw per statement: the order of a call's arguments is the
    // compiler's (y first keeps the scenes of earlier builds).
    const double y = rng.Uniform(1.0, h - 1.0);
    const double x = rng.Uniform(1.0, w - 1.0);
    feature.xy = Eigen::Vector2f(static_cast<float>(x), static_cast<float>(y));
    image->features.push_back(feature);
  }
  // Fisher-Yates shuffle: keypoint order carries no information.
  for (size_t k = image->features.size(); k > 1; --k) {
    std::swap(image->features[k - 1],
              image->features[rng.UniformInt(static_cast<uint32_t>(k))]);
  }
  for (uint32_t k = 0; k < image->features.size(); ++k) {
    const uint32_t pi = image->features[k].point_index;
    if (pi != kNoScenePoint) {
      image->appearance_index.emplace_back(layout.points[pi].appearance, k);
    }
  }
  std::sort(image->appearance_index.begin(), image->appearance_index.end());
}

}  // namespace

Keypoints SynthImage::KeypointMatrix() const {
  Keypoints keypoints(features.size(), 2);
  for (size_t k = 0; k < features.size(); ++k) {
    keypoints(k, 0) = features[k].xy.x();
    keypoints(k, 1) = features[k].xy.y();
  }
  return keypoints;
}

size_t SyntheticScene::NumKeypoints() const {
  size_t n = 0;
  for (const SynthImage& image : images) n += image.features.size();
  return n;
}

std::string SynthImageName(size_t index) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%06zu.png", index);
  return buffer;
}

Eigen::Vector2d ProjectPoint(const Eigen::Matrix3d& K,
                             const Rigid3d& cam_from_world,
                             const Eigen::Vector3d& xyz) {
  return (K * (cam_from_world * xyz)).hnormalized();
}

SyntheticScene GenerateScene(const SynthOptions& options) {
  options.Check();
  SyntheticScene scene;
  scene.options = options;
  scene.layout = BuildSceneLayout(options);

  const double f = options.focal_length;
  const double cx = 0.5 * options.image_width;
  const double cy = 0.5 * options.image_height;
  scene.camera.camera_id = 1;
  scene.camera.model_id = ModelIdOfName(options.camera_model);
  scene.camera.width = options.image_width;
  scene.camera.height = options.image_height;
  if (options.camera_model == "SIMPLE_PINHOLE") {
    scene.camera.params = {f, cx, cy};
  } else if (options.camera_model == "PINHOLE") {
    scene.camera.params = {f, f, cx, cy};
  } else {
    scene.camera.params = {f, cx, cy, 0.0};
  }
  scene.K << f, 0, cx, 0, f, cy, 0, 0, 1;

  const PointGrid grid(scene.layout.points,
                       std::max(1.0, scene.layout.max_view_distance / 8.0));
  scene.images.resize(scene.layout.cams_from_world.size());
  ParallelFor(scene.images.size(), options.num_threads, [&](size_t i) {
    GenerateImage(scene, grid, i, &scene.images[i]);
  });
  return scene;
}

Reconstruction BuildGroundTruthModel(const SyntheticScene& scene) {
  Reconstruction model;
  model.cameras[scene.camera.camera_id] = scene.camera;

  // Tracks of every observed point.
  std::unordered_map<uint32_t, std::vector<TrackElement>> tracks;
  for (const SynthImage& image : scene.images) {
    for (uint32_t k = 0; k < image.features.size(); ++k) {
      const uint32_t pi = image.features[k].point_index;
      if (pi != kNoScenePoint) tracks[pi].push_back({image.image_id, k});
    }
  }

  for (const SynthImage& image : scene.images) {
    Image& out = model.images[image.image_id];
    out.image_id = image.image_id;
    out.camera_id = scene.camera.camera_id;
    out.name = image.name;
    out.cam_from_world = image.cam_from_world;
    out.points2D.resize(image.features.size());
    for (size_t k = 0; k < image.features.size(); ++k) {
      const SynthFeature& feature = image.features[k];
      out.points2D[k].xy = feature.xy.cast<double>();
      if (feature.point_index != kNoScenePoint &&
          tracks.at(feature.point_index).size() >= 2) {
        out.points2D[k].point3D_id = feature.point_index + 1;
      }
    }
  }

  for (const auto& [pi, track] : tracks) {
    if (track.size() < 2) continue;
    const ScenePoint& p = scene.layout.points[pi];
    Point3D& point = model.points3D[pi + 1];
    point.xyz = p.xyz;
    const uint32_t hash = DeriveSeed(p.appearance, 7);
    point.color = Eigen::Matrix<uint8_t, 3, 1>(
        64 + (hash & 0x7f), 64 + ((hash >> 8) & 0x7f), 64 + ((hash >> 16) & 0x7f));
    double error_sum = 0.0;
    for (const TrackElement& element : track) {
      const SynthImage& image = scene.images[element.image_id - 1];
      const Eigen::Vector2d proj =
          ProjectPoint(scene.K, image.cam_from_world, p.xyz);
      error_sum += (proj - image.features[element.point2D_idx].xy.cast<double>())
                       .norm();
    }
    point.error = error_sum / track.size();
    point.track = track;
    std::sort(point.track.begin(), point.track.end(),
              [](const TrackElement& a, const TrackElement& b) {
                return a.image_id < b.image_id;
              });
  }
  return model;
}

}  // namespace hisfm
