#include "hisfm/synth/synthetic_scene.h"

#include <gtest/gtest.h>

#include <cmath>
#include <map>
#include <set>

#include "hisfm/util/error.h"

namespace hisfm {
namespace {

SynthOptions SmallOptions(const std::string& scene, int num_images = 12) {
  SynthOptions options;
  options.scene = scene;
  options.num_images = num_images;
  options.seed = 5;
  options.num_threads = 2;
  return options;
}

TEST(SynthOptions, RejectsInvalidValues) {
  SynthOptions options;
  EXPECT_NO_THROW(options.Check());
  options.scene = "castle";
  EXPECT_THROW(options.Check(), Error);
  options = SynthOptions();
  options.num_images = 1;
  EXPECT_THROW(options.Check(), Error);
  options = SynthOptions();
  options.two_view_geometry = "magic";
  EXPECT_THROW(options.Check(), Error);
  options = SynthOptions();
  options.camera_model = "OPENCV";
  EXPECT_THROW(options.Check(), Error);
  EXPECT_EQ(ParseSynthSceneType("street_control"),
            SynthSceneType::kStreetControl);
  EXPECT_EQ(SynthSceneTypeName(SynthSceneType::kSymmetric4), "symmetric4");
}

TEST(SceneLayout, LookAtCentresTheTarget) {
  const Eigen::Vector3d center(4, 1, 1.5), target(0, 0, 0.8);
  const Rigid3d cam_from_world = LookAt(center, target);
  const Eigen::Vector3d t = cam_from_world * target;
  EXPECT_NEAR(t.x(), 0.0, 1e-9);
  EXPECT_NEAR(t.y(), 0.0, 1e-9);
  EXPECT_GT(t.z(), 0.0);
  EXPECT_NEAR((cam_from_world * center).norm(), 0.0, 1e-9);
  // Image y points down: a point above the target has a smaller v.
  EXPECT_LT((cam_from_world * (target + Eigen::Vector3d::UnitZ())).y(), 0.0);
}

TEST(SceneLayout, CylinderOccluder) {
  CylinderOccluder cylinder;
  cylinder.radius = 1.0;
  cylinder.z_min = 0.0;
  cylinder.z_max = 2.0;
  EXPECT_TRUE(cylinder.Occludes({-3, 0, 1}, {3, 0, 1}));
  EXPECT_FALSE(cylinder.Occludes({-3, 1.5, 1}, {3, 1.5, 1}));
  EXPECT_FALSE(cylinder.Occludes({-3, 0, 3}, {3, 0, 3}));   // above
  EXPECT_TRUE(cylinder.Occludes({-3, 0, 3}, {0, 0, -1}));   // through the top
  EXPECT_FALSE(cylinder.Occludes({-3, 0, 1}, {-2, 0, 1}));  // stops before
}

TEST(SceneLayout, SymmetryMapsReplicasOntoEachOther) {
  for (const std::string scene : {"symmetric2", "symmetric4", "street"}) {
    const SceneLayout layout = BuildSceneLayout(SmallOptions(scene, 20));
    std::map<std::pair<uint32_t, int>, const ScenePoint*> by_appearance;
    for (const ScenePoint& p : layout.points) {
      if (p.on_object) by_appearance[{p.appearance, p.replica}] = &p;
    }
    size_t checked = 0;
    for (const ScenePoint& p : layout.points) {
      if (!p.on_object) continue;
      auto it = by_appearance.find({p.appearance, p.replica + 1});
      if (it == by_appearance.end()) continue;
      const int k = layout.symmetry.Relation(p.replica, p.replica + 1);
      const Rigid3d g = layout.symmetry.Transform(k);
      EXPECT_LT((g * p.xyz - it->second->xyz).norm(), 1e-9) << scene;
      EXPECT_LT((g.rotation * p.normal - it->second->normal).norm(), 1e-9);
      ++checked;
    }
    EXPECT_GT(checked, 500u) << scene;
  }
}

TEST(SceneLayout, ControlScenesHaveUniqueAppearances) {
  for (const std::string scene : {"object_control", "street_control"}) {
    const SceneLayout layout = BuildSceneLayout(SmallOptions(scene, 20));
    std::set<uint32_t> ids;
    for (const ScenePoint& p : layout.points) ids.insert(p.appearance);
    EXPECT_EQ(ids.size(), layout.points.size()) << scene;
    EXPECT_EQ(layout.symmetry.Elements().size(), 1u);
  }
  // The symmetric scene repeats its object print.
  const SceneLayout layout = BuildSceneLayout(SmallOptions("symmetric2", 20));
  std::set<uint32_t> ids;
  for (const ScenePoint& p : layout.points) ids.insert(p.appearance);
  EXPECT_LT(ids.size(), layout.points.size());
}

TEST(SyntheticScene, GroundTruthReprojectsKeypointsWithinNoise) {
  for (const std::string& scene : SynthSceneNames()) {
    const SynthOptions options = SmallOptions(scene);
    const SyntheticScene synth = GenerateScene(options);
    const Reconstruction gt = BuildGroundTruthModel(synth);
    ASSERT_EQ(gt.images.size(), static_cast<size_t>(options.num_images));
    ASSERT_EQ(gt.cameras.size(), 1u);
    double sum_sq = 0.0;
    size_t n = 0;
    for (const auto& [image_id, image] : gt.images) {
      EXPECT_EQ(image.name, SynthImageName(image_id - 1));
      EXPECT_GT(image.points2D.size(), 100u) << scene;
      for (const Point2D& p2 : image.points2D) {
        EXPECT_GE(p2.xy.x(), 0.0);
        EXPECT_LE(p2.xy.x(), options.image_width);
        EXPECT_GE(p2.xy.y(), 0.0);
        EXPECT_LE(p2.xy.y(), options.image_height);
        if (p2.point3D_id == kInvalidPoint3DId) continue;
        const Eigen::Vector2d proj = ProjectPoint(
            synth.K, image.cam_from_world, gt.points3D.at(p2.point3D_id).xyz);
        const double err = (proj - p2.xy).norm();
        EXPECT_LT(err, 6.0 * options.keypoint_noise) << scene;
        sum_sq += err * err;
        ++n;
      }
    }
    ASSERT_GT(n, 1000u) << scene;
    // E|e|^2 = 2 sigma^2 for isotropic 2D noise.
    const double rms_per_axis = std::sqrt(sum_sq / n / 2.0);
    EXPECT_NEAR(rms_per_axis, options.keypoint_noise, 0.1) << scene;
    // Tracks reference existing keypoints that point back at them.
    for (const auto& [point_id, point] : gt.points3D) {
      ASSERT_GE(point.track.size(), 2u);
      for (const TrackElement& e : point.track) {
        EXPECT_EQ(gt.images.at(e.image_id).points2D.at(e.point2D_idx).point3D_id,
                  point_id);
      }
    }
  }
}

TEST(SyntheticScene, BackgroundBehindTheObjectIsHidden) {
  const SyntheticScene synth = GenerateScene(SmallOptions("symmetric2"));
  size_t background = 0;
  for (const SynthImage& image : synth.images) {
    const Eigen::Vector3d center = image.cam_from_world.Inverse().translation;
    for (const SynthFeature& f : image.features) {
      if (f.point_index == kNoScenePoint) continue;
      const ScenePoint& p = synth.layout.points[f.point_index];
      // Visible surfaces face the camera.
      EXPECT_GT(p.normal.dot(center - p.xyz), 0.0);
      if (p.on_object) continue;
      ++background;
      EXPECT_FALSE(synth.layout.occluders[0].Occludes(center, p.xyz));
    }
  }
  EXPECT_GT(background, 100u);
}

TEST(SyntheticScene, DeterministicInSeedAndThreads) {
  SynthOptions options = SmallOptions("street", 10);
  options.num_threads = 1;
  const SyntheticScene a = GenerateScene(options);
  options.num_threads = 2;
  const SyntheticScene b = GenerateScene(options);
  options.seed = 6;
  const SyntheticScene c = GenerateScene(options);
  ASSERT_EQ(a.images.size(), b.images.size());
  bool differs_from_c = false;
  for (size_t i = 0; i < a.images.size(); ++i) {
    const Keypoints ka = a.images[i].KeypointMatrix();
    const Keypoints kb = b.images[i].KeypointMatrix();
    ASSERT_EQ(ka.rows(), kb.rows());
    EXPECT_TRUE(ka == kb);
    const Keypoints kc = c.images[i].KeypointMatrix();
    if (kc.rows() != ka.rows() || !(kc == ka)) differs_from_c = true;
  }
  EXPECT_TRUE(differs_from_c);
}

}  // namespace
}  // namespace hisfm
