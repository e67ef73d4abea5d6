// Test helper of the report layer (used by its *_test.cc only): small
// in-memory models with known geometry.
#pragma once

#include <Eigen/Geometry>
#include <cmath>
#include <random>
#include <string>

#include "hisfm/io/model.h"

namespace hisfm {
namespace testing_scene {

/// cam_from_world of a camera at `center` looking at `target`, with `up`
/// appearing upwards in the image (COLMAP: x right, y down, z forward).
inline Rigid3d LookAt(const Eigen::Vector3d& center,
                      const Eigen::Vector3d& target,
                      const Eigen::Vector3d& up) {
  const Eigen::Vector3d z = (target - center).normalized();
  const Eigen::Vector3d x = z.cross(up).normalized();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d world_from_cam;
  world_from_cam << x, y, z;
  const Eigen::Matrix3d R = world_from_cam.transpose();
  return Rigid3d(Eigen::Quaterniond(R), -(R * center));
}

/// `num_images` cameras on a circle of `radius` around the origin (in the
/// plane z = 0), looking at the origin with +z up, named "img_000.jpg",...,
/// and `num_points` coloured points on a small cylinder around the origin,
/// each observed by two cameras; everything then moved by `world_from_local`.
inline Reconstruction RingModel(int num_images, int num_points, double radius,
                                const Rigid3d& world_from_local = Rigid3d(),
                                uint32_t seed = 1) {
  Reconstruction model;
  Camera camera;
  camera.camera_id = 1;
  camera.model_id = 0;  // SIMPLE_PINHOLE
  camera.width = 640;
  camera.height = 480;
  camera.params = {500, 320, 240};
  model.cameras[1] = camera;
  const Eigen::Vector3d up = world_from_local.rotation * Eigen::Vector3d::UnitZ();
  const double kPi = 3.14159265358979323846;
  for (int i = 0; i < num_images; ++i) {
    const double a = 2 * kPi * i / num_images;
    const Eigen::Vector3d c =
        world_from_local * Eigen::Vector3d(radius * std::cos(a),
                                           radius * std::sin(a), 0.0);
    Image image;
    image.image_id = static_cast<ImageId>(i + 1);
    image.camera_id = 1;
    char name[32];
    std::snprintf(name, sizeof(name), "img_%03d.jpg", i);
    image.name = name;
    image.cam_from_world =
        LookAt(c, world_from_local * Eigen::Vector3d::Zero(), up);
    model.images[image.image_id] = image;
  }
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int k = 0; k < num_points; ++k) {
    const double a = 2 * kPi * u(rng);
    Point3D p;
    p.xyz = world_from_local *
            Eigen::Vector3d(0.2 * radius * std::cos(a),
                            0.2 * radius * std::sin(a), 0.3 * (u(rng) - 0.5));
    p.color << static_cast<uint8_t>(255 * u(rng)),
        static_cast<uint8_t>(255 * u(rng)), static_cast<uint8_t>(255 * u(rng));
    p.error = 0.5 + u(rng);
    for (int t = 0; t < 2; ++t) {
      const ImageId id =
          static_cast<ImageId>(1 + (k + t) % std::max(num_images, 1));
      Image& image = model.images[id];
      p.track.push_back(
          {id, static_cast<Point2DIdx>(image.points2D.size())});
      Point2D obs;
      obs.point3D_id = static_cast<Point3DId>(k + 1);
      image.points2D.push_back(obs);
    }
    model.points3D[static_cast<Point3DId>(k + 1)] = p;
  }
  return model;
}

}  // namespace testing_scene
}  // namespace hisfm
