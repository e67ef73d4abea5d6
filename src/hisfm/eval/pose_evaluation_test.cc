#include "hisfm/eval/pose_evaluation.h"

#include <gtest/gtest.h>

#include <random>

#include "hisfm/util/error.h"
#include "hisfm/util/test_util.h"

namespace hisfm {
namespace {

// Cameras on a circle of radius 5 in the z = 0 plane (with a little height
// jitter), all looking at the origin: like the cup scene.
Reconstruction MakeCircleModel(int n, uint32_t seed = 1) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> jitter(-0.2, 0.2);
  Reconstruction model;
  Camera camera;
  camera.camera_id = 1;
  camera.model_id = 0;
  camera.width = 100;
  camera.height = 100;
  camera.params = {100.0, 50.0, 50.0};
  model.cameras[1] = camera;
  for (int i = 0; i < n; ++i) {
    const double angle = 2.0 * M_PI * i / n;
    const Eigen::Vector3d center(5.0 * std::cos(angle), 5.0 * std::sin(angle),
                                 jitter(rng));
    const Eigen::Vector3d z = (-center).normalized();
    const Eigen::Vector3d x = Eigen::Vector3d::UnitZ().cross(z).normalized();
    const Eigen::Vector3d y = z.cross(x);
    Eigen::Matrix3d world_from_cam;
    world_from_cam << x, y, z;
    Image image;
    image.image_id = static_cast<ImageId>(i + 1);
    image.camera_id = 1;
    image.name = "img" + std::to_string(1000 + i) + ".jpg";
    image.cam_from_world =
        Rigid3d(Eigen::Quaterniond(world_from_cam.transpose()), Eigen::Vector3d::Zero());
    image.cam_from_world.translation =
        -(image.cam_from_world.rotation * center);
    model.images[image.image_id] = image;
  }
  return model;
}

Sim3d SomeSimilarity() {
  Sim3d sim;
  sim.scale = 0.37;
  sim.rotation =
      Eigen::Quaterniond(Eigen::AngleAxisd(1.1, Eigen::Vector3d(1, -2, 0.5)
                                                    .normalized()));
  sim.translation = Eigen::Vector3d(3.0, -7.0, 12.0);
  return sim;
}

Reconstruction Transformed(const Reconstruction& model, const Sim3d& sim) {
  Reconstruction out = model;
  for (auto& [id, image] : out.images) {
    image.cam_from_world = sim.TransformPose(image.cam_from_world);
  }
  return out;
}

TEST(PoseEvaluation, IdenticalModelIsCorrect) {
  const Reconstruction reference = MakeCircleModel(40);
  const PoseEvaluation e =
      EvaluateModel(reference, reference, PoseEvaluationOptions());
  EXPECT_EQ(e.num_reference_images, 40u);
  EXPECT_EQ(e.num_registered, 40u);
  EXPECT_TRUE(e.missing_images.empty());
  EXPECT_TRUE(e.unknown_images.empty());
  EXPECT_EQ(e.num_pairs, 780u);
  EXPECT_NEAR(e.median_rotation_error_deg, 0.0, 1e-6);
  EXPECT_NEAR(e.median_translation_error_deg, 0.0, 1e-6);
  ASSERT_EQ(e.pair_fractions_within.size(), 3u);
  for (const double f : e.pair_fractions_within) EXPECT_EQ(f, 1.0);
  EXPECT_TRUE(e.aligned);
  EXPECT_EQ(e.num_alignment_inliers, 40u);
  EXPECT_NEAR(e.median_center_error, 0.0, 1e-9);
  EXPECT_NEAR(e.mean_center_error, 0.0, 1e-9);
  EXPECT_TRUE(e.correct);
  EXPECT_TRUE(e.verdict_reason.empty());
  const std::string text = FormatPoseEvaluation(e);
  EXPECT_NE(text.find("registered: 40/40"), std::string::npos) << text;
  EXPECT_NE(text.find("verdict: correct\n"), std::string::npos) << text;
}

TEST(PoseEvaluation, SimilarityTransformedModelIsCorrectAndAligned) {
  const Reconstruction reference = MakeCircleModel(30);
  const Sim3d sim = SomeSimilarity();
  const PoseEvaluation e = EvaluateModel(Transformed(reference, sim),
                                         reference, PoseEvaluationOptions());
  EXPECT_NEAR(e.median_rotation_error_deg, 0.0, 1e-6);
  EXPECT_NEAR(e.median_translation_error_deg, 0.0, 1e-6);
  EXPECT_EQ(e.pair_fractions_within[0], 1.0);
  EXPECT_TRUE(e.correct);
  ASSERT_TRUE(e.aligned);
  // The alignment recovers the inverse of the applied transform.
  const Sim3d inv = sim.Inverse();
  EXPECT_NEAR(e.reference_from_model.scale, inv.scale, 1e-9);
  EXPECT_LT(e.reference_from_model.rotation.angularDistance(inv.rotation),
            1e-9);
  EXPECT_LT((e.reference_from_model.translation - inv.translation).norm(),
            1e-8);
  EXPECT_NEAR(e.mean_center_error, 0.0, 1e-9);
}

TEST(PoseEvaluation, FoldedCamerasAreIncorrect) {
  const int n = 40, k = 10;
  const Reconstruction reference = MakeCircleModel(n);
  // A fold: 10 cameras turned by 180 degrees about the circle's axis, so
  // that they land on the other half of the circle, still looking inwards.
  Sim3d fold;
  fold.rotation = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitZ());
  Reconstruction model = reference;
  for (ImageId id = 3; id < 3 + k; ++id) {
    model.images[id].cam_from_world =
        fold.TransformPose(model.images[id].cam_from_world);
  }
  const PoseEvaluation e =
      EvaluateModel(model, reference, PoseEvaluationOptions());
  const double expected =
      static_cast<double>(k * (k - 1) / 2 + (n - k) * (n - k - 1) / 2) /
      (n * (n - 1) / 2);
  EXPECT_DOUBLE_EQ(e.verdict_pair_fraction, expected);
  for (const double f : e.pair_fractions_within) EXPECT_DOUBLE_EQ(f, expected);
  EXPECT_FALSE(e.correct);
  EXPECT_NE(e.verdict_reason.find("61.5% of pairs within 5 deg"),
            std::string::npos)
      << e.verdict_reason;
  // The alignment follows the 30 unfolded cameras.
  EXPECT_EQ(e.num_alignment_inliers, static_cast<size_t>(n - k));
  EXPECT_NEAR(e.median_center_error, 0.0, 1e-9);
  EXPECT_GT(e.mean_center_error, 0.1);
  EXPECT_NE(FormatPoseEvaluation(e).find("verdict: incorrect ("),
            std::string::npos);
}

// Cameras along a straight street: centre i at (i, 0, 0.05 (i mod 2)), all
// looking down +y at one facade.
Reconstruction MakeStreetModel(int n) {
  Reconstruction model = MakeCircleModel(1);
  model.images.clear();
  Eigen::Matrix3d world_from_cam;
  world_from_cam << Eigen::Vector3d::UnitX(), -Eigen::Vector3d::UnitZ(),
      Eigen::Vector3d::UnitY();
  for (int i = 0; i < n; ++i) {
    Image image;
    image.image_id = static_cast<ImageId>(i + 1);
    image.camera_id = 1;
    image.name = "street" + std::to_string(1000 + i) + ".jpg";
    image.cam_from_world.rotation =
        Eigen::Quaterniond(world_from_cam.transpose());
    image.cam_from_world.translation =
        -(image.cam_from_world.rotation *
          Eigen::Vector3d(i, 0.0, 0.05 * (i % 2)));
    model.images[image.image_id] = image;
  }
  return model;
}

TEST(PoseEvaluation, StretchSlidAlongAStreetFailsOnlyTheCentreCheck) {
  const int n = 60, k = 10;
  const Reconstruction reference = MakeStreetModel(n);
  // The last 10 cameras slide 20 m further along the street, as a stretch
  // glued to the wrong repetition of a facade does: every pair keeps its
  // relative rotation and (within 3 degrees) its direction.
  Reconstruction model = reference;
  for (ImageId id = n - k + 1; id <= n; ++id) {
    Image& image = model.images[id];
    image.cam_from_world.translation -=
        image.cam_from_world.rotation * Eigen::Vector3d(20.0, 0.0, 0.0);
  }
  PoseEvaluationOptions options;
  PoseEvaluation e = EvaluateModel(model, reference, options);
  EXPECT_EQ(e.verdict_pair_fraction, 1.0);
  ASSERT_TRUE(e.aligned);
  EXPECT_EQ(e.num_alignment_inliers, static_cast<size_t>(n - k));
  EXPECT_DOUBLE_EQ(e.center_fraction_within,
                   static_cast<double>(n - k) / n);
  EXPECT_FALSE(e.correct);
  EXPECT_EQ(e.verdict_reason,
            "83.3% of camera centres within 5.0% of the scene extent "
            "(needs 95.0%)");
  EXPECT_NE(FormatPoseEvaluation(e).find("83.3% within 5.0%"),
            std::string::npos)
      << FormatPoseEvaluation(e);
  const nlohmann::json j = ToJson(e);
  EXPECT_DOUBLE_EQ(j["camera_centers"]["fraction_within"].get<double>(),
                   static_cast<double>(n - k) / n);
  EXPECT_EQ(j["camera_centers"]["threshold"], 0.05);

  // With the centre check off, or a threshold above the slide (20 m of a
  // 59 m extent), the slide passes.
  options.min_correct_center_fraction = 0.0;
  EXPECT_TRUE(EvaluateModel(model, reference, options).correct);
  options = PoseEvaluationOptions();
  options.center_threshold = 0.5;
  EXPECT_TRUE(EvaluateModel(model, reference, options).correct);
  // Unmoved, the street is right by both checks.
  e = EvaluateModel(reference, reference, PoseEvaluationOptions());
  EXPECT_TRUE(e.correct) << e.verdict_reason;
  EXPECT_EQ(e.center_fraction_within, 1.0);
}

TEST(PoseEvaluation, SmallRotationErrorsAreMeasured) {
  const Reconstruction reference = MakeCircleModel(20);
  Reconstruction model = reference;
  // Rotating one camera about its own centre by 3 degrees changes its
  // relative rotations by 3 degrees and leaves baselines' directions in
  // the other cameras' frames unchanged.
  Image& image = model.images[5];
  const Eigen::Vector3d center = image.ProjectionCenter();
  image.cam_from_world.rotation =
      Eigen::AngleAxisd(3.0 * M_PI / 180.0, Eigen::Vector3d::UnitX()) *
      image.cam_from_world.rotation;
  image.cam_from_world.translation = -(image.cam_from_world.rotation * center);
  const PoseEvaluation e =
      EvaluateModel(model, reference, PoseEvaluationOptions());
  // 19 of 190 pairs involve the camera; their pair error is 3 degrees.
  EXPECT_DOUBLE_EQ(e.pair_fractions_within[0], 171.0 / 190.0);
  EXPECT_DOUBLE_EQ(e.pair_fractions_within[1], 1.0);
  EXPECT_TRUE(e.correct);
  EXPECT_NEAR(e.median_rotation_error_deg, 0.0, 1e-6);
  EXPECT_NEAR(RotationErrorDeg(model.images[5].cam_from_world.rotation,
                               reference.images.at(5).cam_from_world.rotation),
              3.0, 1e-9);
}

TEST(PoseEvaluation, MissingImagesAreNotCorrect) {
  const Reconstruction reference = MakeCircleModel(25);
  Reconstruction model = reference;
  model.images.erase(4);
  model.images.erase(9);
  Image extra = model.images[1];
  extra.image_id = 100;
  extra.name = "extra.jpg";
  model.images[100] = extra;
  PoseEvaluationOptions options;
  const PoseEvaluation e = EvaluateModel(model, reference, options);
  EXPECT_EQ(e.num_registered, 23u);
  EXPECT_EQ(e.num_model_images, 24u);
  EXPECT_EQ(e.missing_images,
            (std::vector<std::string>{"img1003.jpg", "img1008.jpg"}));
  EXPECT_EQ(e.unknown_images, (std::vector<std::string>{"extra.jpg"}));
  EXPECT_EQ(e.pair_fractions_within[1], 1.0);
  EXPECT_FALSE(e.correct);
  EXPECT_NE(e.verdict_reason.find("2 of 25 reference images not registered"),
            std::string::npos);
  options.require_all_registered = false;
  EXPECT_TRUE(EvaluateModel(model, reference, options).correct);
}

TEST(PoseEvaluation, TooFewImages) {
  const Reconstruction reference = MakeCircleModel(10);
  Reconstruction model = reference;
  model.images.erase(model.images.begin(), std::next(model.images.begin(), 9));
  const PoseEvaluation e =
      EvaluateModel(model, reference, PoseEvaluationOptions());
  EXPECT_EQ(e.num_pairs, 0u);
  EXPECT_FALSE(e.aligned);
  EXPECT_FALSE(e.correct);
  EXPECT_TRUE(std::isnan(e.median_rotation_error_deg));
  const nlohmann::json j = ToJson(e);
  EXPECT_TRUE(j["median_rotation_error_deg"].is_null());
  EXPECT_TRUE(j["camera_centers"]["median_error"].is_null());
  EXPECT_TRUE(j["camera_centers"]["fraction_within"].is_null());
  EXPECT_TRUE(std::isnan(e.center_fraction_within));
  EXPECT_EQ(j["verdict"], "incorrect");
  // Valid JSON text that reads back the same (a NaN would come back null).
  EXPECT_EQ(nlohmann::json::parse(j.dump()), j);
}

TEST(PoseEvaluation, JsonHasTheNumbers) {
  const Reconstruction reference = MakeCircleModel(12);
  const PoseEvaluation e =
      EvaluateModel(reference, reference, PoseEvaluationOptions());
  const nlohmann::json j = nlohmann::json::parse(ToJson(e).dump());
  EXPECT_EQ(j["num_registered"], 12);
  EXPECT_EQ(j["num_reference_images"], 12);
  EXPECT_EQ(j["num_pairs"], 66);
  EXPECT_EQ(j["pairs_within"].size(), 3u);
  EXPECT_EQ(j["pairs_within"][1]["threshold_deg"], 5.0);
  EXPECT_EQ(j["pairs_within"][1]["fraction"], 1.0);
  EXPECT_EQ(j["correct"], true);
  EXPECT_EQ(j["verdict"], "correct");
  EXPECT_EQ(j["camera_centers"]["num_alignment_inliers"], 12);
}

TEST(PoseEvaluation, OptionsAreChecked) {
  PoseEvaluationOptions options;
  options.min_correct_pair_fraction = 1.5;
  EXPECT_THROW(options.Check(), Error);
  options = PoseEvaluationOptions();
  options.pair_thresholds_deg.clear();
  EXPECT_THROW(options.Check(), Error);
  options = PoseEvaluationOptions();
  options.alignment.num_iterations = -1;
  EXPECT_THROW(options.Check(), Error);
  options = PoseEvaluationOptions();
  options.center_threshold = 0.0;
  EXPECT_THROW(options.Check(), Error);
  options = PoseEvaluationOptions();
  options.min_correct_center_fraction = -0.1;
  EXPECT_THROW(options.Check(), Error);
}

// Splits `reference` into models holding the images with ids in each range,
// each in its own similarity frame.
std::vector<Reconstruction> Split(const Reconstruction& reference,
                                  const std::vector<ImageId>& first_ids) {
  std::vector<Reconstruction> models;
  for (size_t m = 0; m < first_ids.size(); ++m) {
    const ImageId end = m + 1 < first_ids.size()
                            ? first_ids[m + 1]
                            : std::numeric_limits<ImageId>::max();
    Reconstruction model = reference;
    for (auto it = model.images.begin(); it != model.images.end();) {
      if (it->first < first_ids[m] || it->first >= end) {
        it = model.images.erase(it);
      } else {
        ++it;
      }
    }
    Sim3d sim = SomeSimilarity();
    sim.scale *= 1.0 + m;
    models.push_back(Transformed(model, sim));
  }
  return models;
}

TEST(MultiModelEvaluation, SplitSceneIsOversplit) {
  const Reconstruction reference = MakeCircleModel(40);
  const MultiModelEvaluation e = EvaluateModels(
      Split(reference, {1, 13, 39}), reference, PoseEvaluationOptions());
  EXPECT_EQ(e.model_sizes, (std::vector<size_t>{12, 26, 2}));
  EXPECT_EQ(e.num_large_models, 2u);
  EXPECT_TRUE(e.oversplit);
  EXPECT_EQ(e.largest_model, 1u);
  EXPECT_EQ(e.largest.num_registered, 26u);
  EXPECT_EQ(e.num_registered_any, 40u);
  EXPECT_EQ(e.num_pairs_within_models, 66u + 325u + 1u);
  for (const double f : e.pair_fractions_within_models) EXPECT_EQ(f, 1.0);
  ASSERT_EQ(e.per_model.size(), 3u);
  EXPECT_EQ(e.per_model[0].num_registered, 12u);
  EXPECT_FALSE(e.correct);
  EXPECT_TRUE(e.each_model_right);
  EXPECT_NE(e.verdict_reason.find("split into 2 models"), std::string::npos)
      << e.verdict_reason;
  const std::string text = FormatMultiModelEvaluation(e);
  EXPECT_NE(text.find("oversplit: yes"), std::string::npos) << text;
  EXPECT_NE(text.find("verdict: incorrect"), std::string::npos) << text;
  const nlohmann::json j = ToJson(e);
  EXPECT_EQ(j["oversplit"], true);
  EXPECT_EQ(j["each_model_right"], true);
  EXPECT_EQ(j["num_models"], 3);
  EXPECT_EQ(j["largest"]["num_registered"], 26);

  // A fold of 10 cameras inside the larger part: split and folded.
  std::vector<Reconstruction> parts = Split(reference, {1, 13, 39});
  Sim3d fold;
  fold.rotation = Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitZ());
  for (ImageId id = 14; id < 24; ++id) {
    Rigid3d& pose = parts[1].images.at(id).cam_from_world;
    pose = fold.TransformPose(pose);
  }
  const MultiModelEvaluation folded =
      EvaluateModels(parts, reference, PoseEvaluationOptions());
  EXPECT_TRUE(folded.oversplit);
  EXPECT_FALSE(folded.each_model_right);
}

TEST(MultiModelEvaluation, SmallExtraModelIsNotOversplit) {
  const Reconstruction reference = MakeCircleModel(40);
  PoseEvaluationOptions options;
  options.require_all_registered = false;
  const MultiModelEvaluation e =
      EvaluateModels(Split(reference, {1, 39}), reference, options);
  EXPECT_EQ(e.num_large_models, 1u);
  EXPECT_FALSE(e.oversplit);
  EXPECT_EQ(e.largest_model, 0u);
  EXPECT_TRUE(e.correct);
  // With every image required, the 2 images of the small model are missing
  // from the largest one.
  options.require_all_registered = true;
  EXPECT_FALSE(
      EvaluateModels(Split(reference, {1, 39}), reference, options).correct);
}

TEST(MultiModelEvaluation, OneModelMatchesEvaluateModel) {
  const Reconstruction reference = MakeCircleModel(20);
  const MultiModelEvaluation e =
      EvaluateModels({reference}, reference, PoseEvaluationOptions());
  EXPECT_TRUE(e.correct);
  EXPECT_FALSE(e.oversplit);
  EXPECT_EQ(FormatMultiModelEvaluation(e), FormatPoseEvaluation(e.largest));
  EXPECT_THROW(EvaluateModels({}, reference, PoseEvaluationOptions()), Error);
}

TEST(PoseEvaluation, CupReferenceAgainstItselfIsCorrect) {
  const std::string path = SharedDataPath("yan2017/cup", "reference");
  if (path.empty()) {
    GTEST_SKIP() << "shared data absent: no yan2017/cup/reference under "
                 << SharedDataDir();
  }
  const Reconstruction reference = ReadModel(path);
  const PoseEvaluation e =
      EvaluateModel(reference, reference, PoseEvaluationOptions());
  EXPECT_EQ(e.num_registered, 64u);
  EXPECT_EQ(e.num_pairs, 64u * 63u / 2u);
  EXPECT_NEAR(e.median_rotation_error_deg, 0.0, 1e-6);
  EXPECT_EQ(e.pair_fractions_within[0], 1.0);
  EXPECT_TRUE(e.correct);
}

}  // namespace
}  // namespace hisfm
