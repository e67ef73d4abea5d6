#include "hisfm/recon/conflict_join.h"

#include <gtest/gtest.h>

#include <random>

#include "hisfm/eval/similarity_alignment.h"
#include "hisfm/util/error.h"

namespace hisfm {
namespace {

// A facade pattern of 3 rows x 20 columns 2.5 m apart and 40 unique points
// in front of it, 10 m from two cameras (x = 1 and 7, looking along +y). The
// model holds images 1 and 2 in the world frame; the other model holds
// images 3 and 4 (standing where 1 and 2 do) in a frame a similarity away.
constexpr int kColumns = 20, kRows = 3, kUnique = 40;
constexpr int kNumPoints = kColumns * kRows + kUnique;
constexpr double kFocal = 800.0;

Eigen::Vector3d WorldPoint(int p) {
  if (p < kColumns * kRows) {
    return {2.5 * (p % kColumns), 10.0, -1.0 + (p / kColumns)};
  }
  std::mt19937 rng(p);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  return {15.0 * u(rng), 8.0 + 4.0 * u(rng), -1.5 + 3.0 * u(rng)};
}

Rigid3d CamFromWorld(ImageId id) {
  Eigen::Matrix3d R;
  R << 1, 0, 0, 0, 0, -1, 0, 1, 0;
  const Eigen::Vector3d center(id % 2 == 1 ? 1.0 : 7.0, 0.0, 0.0);
  return Rigid3d(Eigen::Quaterniond(R), -(R * center));
}

Sim3d OtherFromWorld() {
  Sim3d s;
  s.scale = 0.5;
  s.rotation = Eigen::AngleAxisd(1.0, Eigen::Vector3d(1, 2, 3).normalized());
  s.translation = Eigen::Vector3d(-2.0, 4.0, 0.5);
  return s;
}

Reconstruction MakeModel(ImageId first, const Sim3d& frame_from_world) {
  Reconstruction model;
  model.cameras[1] = {1, 0, 1024, 768, {kFocal, 512.0, 384.0}};
  for (ImageId id = first; id < first + 2; ++id) {
    Image image;
    image.image_id = id;
    image.camera_id = 1;
    image.name = "im" + std::to_string(id);
    image.cam_from_world = frame_from_world.TransformPose(CamFromWorld(id));
    for (int p = 0; p < kNumPoints; ++p) {
      image.points2D.push_back({Eigen::Vector2d::Zero(),
                                static_cast<Point3DId>(p + 1)});
    }
    model.images[id] = image;
  }
  for (int p = 0; p < kNumPoints; ++p) {
    Point3D point;
    point.xyz = frame_from_world * WorldPoint(p);
    point.track = {{first, static_cast<Point2DIdx>(p)},
                   {first + 1, static_cast<Point2DIdx>(p)}};
    model.points3D[p + 1] = point;
  }
  return model;
}

PairMatches TruePair(ImageId a, ImageId b) {
  PairMatches pm{ImagePair(a, b), {}};
  for (Point2DIdx p = 0; p < kNumPoints; ++p) pm.matches.push_back({p, p});
  return pm;
}

PairMatches ShiftedPattern(ImageId a, ImageId b, int shift) {
  PairMatches pm{ImagePair(a, b), {}};
  for (int row = 0; row < kRows; ++row) {
    for (int column = 0; column + shift < kColumns; ++column) {
      pm.matches.push_back(
          {static_cast<Point2DIdx>(row * kColumns + column),
           static_cast<Point2DIdx>(row * kColumns + column + shift)});
    }
  }
  return pm;
}

std::unordered_set<Point3DId> PatternPoints() {
  std::unordered_set<Point3DId> out;
  for (int p = 0; p < kColumns * kRows; ++p) out.insert(p + 1);
  return out;
}

ConflictJoinOptions OnePairPerJoin() {
  ConflictJoinOptions options;
  options.min_votes = 1;
  options.min_expected = 10;
  return options;
}

TEST(JoinByLeastConflict, JoinsWhereThePairsMatchTheUniquePointsPredicted) {
  Reconstruction model = MakeModel(1, Sim3d());
  const Reconstruction other = MakeModel(3, OtherFromWorld());
  // Three doppelganger pairs, each shifted by its own number of columns,
  // and one true pair.
  const std::vector<PairMatches> pairs = {
      ShiftedPattern(1, 3, 1), ShiftedPattern(1, 4, 2),
      ShiftedPattern(2, 4, 3), TruePair(2, 3)};
  const ConflictJoinStep step =
      JoinByLeastConflict(other, pairs, PatternPoints(), PatternPoints(),
                          OnePairPerJoin(), ModelMergeOptions(), &model);
  EXPECT_EQ(step.num_fitted_pairs, 4u);
  EXPECT_EQ(step.num_hypotheses, 4u);
  EXPECT_EQ(step.num_votes, 1u);
  EXPECT_GT(step.num_expected, 10u);
  EXPECT_EQ(step.num_found, step.num_expected);
  ASSERT_TRUE(step.merge.merged);
  ASSERT_EQ(model.NumRegImages(), 4u);
  for (ImageId id : {3u, 4u}) {
    const Eigen::Vector3d truth = CamFromWorld(id).Inverse().translation;
    EXPECT_LT((model.images.at(id).ProjectionCenter() - truth).norm(), 1e-6)
        << "image " << id;
  }
}

TEST(FindLeastConflictJoin, NamesTheVotingPairsOfTheBestJoinAndMergesNothing) {
  const Reconstruction model = MakeModel(1, Sim3d());
  const Reconstruction other = MakeModel(3, OtherFromWorld());
  const std::vector<PairMatches> pairs = {
      ShiftedPattern(1, 3, 1), TruePair(2, 3), ShiftedPattern(2, 4, 3)};
  const LeastConflictJoin best =
      FindLeastConflictJoin(model, other, pairs, PatternPoints(),
                            PatternPoints(), OnePairPerJoin(), 0.1);
  EXPECT_TRUE(best.stands_out);
  EXPECT_EQ(best.voting_pairs, std::vector<size_t>{1});
  EXPECT_EQ(best.step.num_found, best.step.num_expected);
  EXPECT_FALSE(best.step.merge.merged);

  // Without the true pair the best join is still named, and does not
  // stand out.
  const LeastConflictJoin wrong = FindLeastConflictJoin(
      model, other, {pairs[0], pairs[2]}, PatternPoints(), PatternPoints(),
      OnePairPerJoin(), 0.1);
  EXPECT_FALSE(wrong.stands_out);
  EXPECT_EQ(wrong.voting_pairs.size(), 1u);
}

// Two photos near each other in a street match some clutter truly even in
// a pair whose matches mostly tie the facade to a shifted copy: under the
// shifted join, those true matches tie each unique point to another point
// than where the join lands it, and count against the join.
TEST(FindLeastConflictJoin, MatchesThatContradictTheJoinAreNotFound) {
  const Reconstruction model = MakeModel(1, Sim3d());
  const Reconstruction other = MakeModel(3, OtherFromWorld());
  PairMatches mixed = ShiftedPattern(2, 3, 2);
  for (Point2DIdx p = kColumns * kRows; p < kColumns * kRows + 30; ++p) {
    mixed.matches.push_back({p, p});
  }
  const LeastConflictJoin shifted =
      FindLeastConflictJoin(model, other, {mixed}, PatternPoints(),
                            PatternPoints(), OnePairPerJoin(), 0.1);
  EXPECT_EQ(shifted.step.num_fitted_pairs, 1u);
  EXPECT_GT(shifted.step.num_expected, 10u);
  EXPECT_EQ(shifted.step.num_found, 0u);
  EXPECT_FALSE(shifted.stands_out);
}

// Families that share voting pairs propose nearly one join and are no
// rivals. With a tolerance of 30% of the depth (3 m at 10 m), a pair whose
// pattern matches shift one column (2.5 m) votes both for the true join and
// for the join two columns off, which the pair shifted by two seeds: the
// two families share it, and the true join stands out against none. A
// rival that shares no voter (five columns off) is the next best, and as
// it finds nearly as much, the true join no longer stands out.
TEST(FindLeastConflictJoin, FamiliesThatShareVotersAreNoRivals) {
  const Reconstruction model = MakeModel(1, Sim3d());
  const Reconstruction other = MakeModel(3, OtherFromWorld());
  std::vector<PairMatches> pairs = {TruePair(2, 3), ShiftedPattern(1, 3, 1),
                                    ShiftedPattern(1, 4, 2)};
  ConflictJoinOptions options = OnePairPerJoin();
  options.max_rotation_deg = 1.0;
  const LeastConflictJoin siblings =
      FindLeastConflictJoin(model, other, pairs, {}, {}, options, 0.3);
  EXPECT_EQ(siblings.step.num_hypotheses, 2u);
  EXPECT_EQ(siblings.voting_pairs, (std::vector<size_t>{0, 1}));
  EXPECT_EQ(siblings.step.next_found_share, 0.0);
  EXPECT_TRUE(siblings.stands_out);

  pairs.push_back(ShiftedPattern(2, 3, 5));
  const LeastConflictJoin rival =
      FindLeastConflictJoin(model, other, pairs, {}, {}, options, 0.3);
  EXPECT_EQ(rival.step.num_hypotheses, 3u);
  EXPECT_EQ(rival.voting_pairs, (std::vector<size_t>{0, 1}));
  EXPECT_GT(rival.step.next_found_share, 0.5);
  EXPECT_FALSE(rival.stands_out);
}

TEST(JoinByLeastConflict, RefusesWhenEveryJoinMissesTheUniquePoints) {
  Reconstruction model = MakeModel(1, Sim3d());
  const Reconstruction other = MakeModel(3, OtherFromWorld());
  const std::vector<PairMatches> pairs = {ShiftedPattern(1, 3, 1),
                                          ShiftedPattern(1, 4, 2),
                                          ShiftedPattern(2, 4, 3)};
  const ConflictJoinStep step =
      JoinByLeastConflict(other, pairs, PatternPoints(), PatternPoints(),
                          OnePairPerJoin(), ModelMergeOptions(), &model);
  EXPECT_EQ(step.num_fitted_pairs, 3u);
  EXPECT_GT(step.num_expected, 0u);
  EXPECT_EQ(step.num_found, 0u);
  EXPECT_FALSE(step.merge.merged);
  EXPECT_EQ(model.NumRegImages(), 2u);
}

TEST(JoinByLeastConflict, AJoinThatDoesNotStandOutIsLeftUndone) {
  // With the pattern taken for unique, the doppelganger joins find much of
  // what they predict matched too (the best of them about 40%), so the true
  // join (100%) stands out by less than 3 times.
  const Reconstruction other = MakeModel(3, OtherFromWorld());
  const std::vector<PairMatches> pairs = {
      ShiftedPattern(1, 3, 1), ShiftedPattern(1, 4, 2),
      ShiftedPattern(2, 4, 3), TruePair(2, 3)};
  ConflictJoinOptions options = OnePairPerJoin();
  options.min_share_ratio = 3.0;
  Reconstruction model = MakeModel(1, Sim3d());
  const ConflictJoinStep step = JoinByLeastConflict(
      other, pairs, {}, {}, options, ModelMergeOptions(), &model);
  EXPECT_EQ(step.num_found, step.num_expected);
  EXPECT_GT(step.next_found_share, 1.0 / 3.0);
  EXPECT_FALSE(step.merge.merged);
  EXPECT_EQ(model.NumRegImages(), 2u);
  options.min_share_ratio = 1.0;
  EXPECT_TRUE(
      JoinByLeastConflict(other, pairs, {}, {}, options, ModelMergeOptions(),
                          &model)
          .merge.merged);
  EXPECT_EQ(model.NumRegImages(), 4u);
}

TEST(JoinByLeastConflict, AJoinNeedsItsVotesAndItsExpectedPoints) {
  const Reconstruction other = MakeModel(3, OtherFromWorld());
  const std::vector<PairMatches> pairs = {TruePair(2, 3)};
  for (const bool votes : {true, false}) {
    Reconstruction model = MakeModel(1, Sim3d());
    ConflictJoinOptions options = OnePairPerJoin();
    if (votes) {
      options.min_votes = 2;
    } else {
      options.min_expected = 1000;
    }
    const ConflictJoinStep step =
        JoinByLeastConflict(other, pairs, PatternPoints(), PatternPoints(),
                            options, ModelMergeOptions(), &model);
    EXPECT_FALSE(step.merge.merged);
    EXPECT_EQ(model.NumRegImages(), 2u);
  }
}

TEST(ConflictJoinOptions, RejectsOutOfRangeValues) {
  auto expect_throw = [](auto change) {
    ConflictJoinOptions options;
    change(&options);
    EXPECT_THROW(options.Check(), Error);
  };
  expect_throw([](ConflictJoinOptions* o) { o->min_pair_correspondences = 2; });
  expect_throw([](ConflictJoinOptions* o) { o->min_pair_inlier_share = 1.5; });
  expect_throw([](ConflictJoinOptions* o) { o->pair_fit_iterations = 0; });
  expect_throw([](ConflictJoinOptions* o) { o->max_rotation_deg = 0.0; });
  expect_throw([](ConflictJoinOptions* o) { o->max_hypotheses = 0; });
  expect_throw([](ConflictJoinOptions* o) { o->min_votes = 0; });
  expect_throw([](ConflictJoinOptions* o) { o->min_expected = 0; });
  expect_throw([](ConflictJoinOptions* o) { o->min_found_share = -0.1; });
  expect_throw([](ConflictJoinOptions* o) { o->min_share_ratio = 0.5; });
  EXPECT_NO_THROW(ConflictJoinOptions().Check());
}

}  // namespace
}  // namespace hisfm
