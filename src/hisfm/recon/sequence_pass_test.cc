#include "hisfm/recon/sequence_pass.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <filesystem>
#include <mutex>
#include <random>
#include <set>

#include "hisfm/eval/similarity_alignment.h"
#include "hisfm/io/database_writer.h"
#include "hisfm/util/error.h"
#include "hisfm/util/file_util.h"
#include "hisfm/util/test_util.h"
#include "hisfm/verify/view_graph_reader.h"

namespace hisfm {
namespace {

namespace fs = std::filesystem;

constexpr int kNumImages = 30;

// A walk of kNumImages photos (ids 1..n in capture order): pairs up to 3
// apart match, inliers falling with the distance, and doppelgangers a
// period of 4 apart match as strongly. Image id k is named by its place in
// `order` (the k-th name of the sequence goes to order[k]).
void WriteWalkDatabase(const std::string& path,
                       const std::vector<ImageId>& order) {
  DatabaseWriter writer(path);
  writer.WriteCamera(SimplePinholeCamera(1, 1024, 768, 800));
  std::vector<std::string> names(kNumImages + 1);
  for (size_t k = 0; k < order.size(); ++k) {
    char buf[32];
    std::snprintf(buf, sizeof(buf), "%06zu.jpg", k);
    names[order[k]] = buf;
  }
  for (ImageId id = 1; id <= kNumImages; ++id) {
    writer.WriteImage({id, names[id], 1});
    Keypoints keypoints(500, 2);
    for (int r = 0; r < 500; ++r) keypoints.row(r) << 2.0f * r, 1.0f * r;
    writer.WriteKeypoints(id, keypoints);
  }
  auto write = [&](ImageId a, ImageId b, uint32_t n) {
    TwoViewGeometry g;
    g.pair = ImagePair(a, b);
    g.config = static_cast<int>(TwoViewConfig::kCalibrated);
    for (uint32_t i = 0; i < n; ++i) g.inlier_matches.push_back({i, i});
    writer.WriteTwoViewGeometry(g);
  };
  for (ImageId i = 1; i <= kNumImages; ++i) {
    for (ImageId d = 1; d <= 3 && i + d <= kNumImages; ++d) {
      write(i, i + d, 400 / d);
    }
    for (ImageId j = i + 4; j <= kNumImages; j += 4) write(i, j, 380);
  }
  writer.Close();
}

std::vector<ImageId> CaptureOrder() {
  std::vector<ImageId> order;
  for (ImageId id = 1; id <= kNumImages; ++id) order.push_back(id);
  return order;
}

// The chain's database holds exactly the consecutive pairs; a chain that
// cannot be reconstructed leaves the input as it is and cleans nothing.
TEST(SequencePass, AFailingChainRemovesNothing) {
  TempDir tmp("hisfm-sequence-pass");
  WriteWalkDatabase(tmp / "database.db", CaptureOrder());
  const std::string before = ReadTextFile(tmp / "database.db");
  int calls = 0;
  const ChainReconstructor failing = [&](const std::string& chain_db) {
    ++calls;
    const Database db(chain_db);
    const ViewGraph chain = ReadViewGraph(db, 1);
    EXPECT_EQ(chain.NumEdges(), static_cast<size_t>(kNumImages - 1));
    for (ImageId i = 1; i < kNumImages; ++i) {
      EXPECT_GT(chain.Weight(i, i + 1), 0u);
    }
    throw Error("no good initial image pair");
    return std::vector<Reconstruction>();
  };
  const SequencePassResult result = RunSequencePass(
      tmp / "database.db", 15, tmp / "work", failing, SequencePassOptions());
  EXPECT_EQ(calls, 1);
  EXPECT_TRUE(result.chain.applies);
  EXPECT_FALSE(result.ran);
  EXPECT_NE(result.note.find("could not be reconstructed"), std::string::npos)
      << result.note;
  EXPECT_TRUE(result.cleaned_database_path.empty());
  EXPECT_EQ(result.num_removed, 0u);
  EXPECT_EQ(ReadTextFile(tmp / "database.db"), before);
}

TEST(SequencePass, ShuffledNamesAreLeftAlone) {
  TempDir tmp("hisfm-sequence-pass");
  std::vector<ImageId> order = CaptureOrder();
  std::mt19937 rng(3);
  std::shuffle(order.begin(), order.end(), rng);
  WriteWalkDatabase(tmp / "database.db", order);
  int calls = 0;
  const ChainReconstructor count = [&](const std::string&) {
    ++calls;
    return std::vector<Reconstruction>();
  };
  const SequencePassResult result = RunSequencePass(
      tmp / "database.db", 15, tmp / "work", count, SequencePassOptions());
  EXPECT_EQ(calls, 0);
  EXPECT_FALSE(result.chain.applies);
  EXPECT_FALSE(result.ran);
  EXPECT_EQ(result.note, "names give no sequence");
  EXPECT_EQ(result.num_input_pairs, ReadViewGraph(Database(tmp / "database.db"), 15).NumEdges());
  EXPECT_EQ(result.ToJson()["applies"], false);
}

// A chain that registers nothing judges nothing: the cleaned copy holds
// every pair, with every inlier.
TEST(SequencePass, NoChainModelKeepsEveryPair) {
  TempDir tmp("hisfm-sequence-pass");
  WriteWalkDatabase(tmp / "database.db", CaptureOrder());
  const ChainReconstructor empty = [](const std::string&) {
    return std::vector<Reconstruction>();
  };
  const SequencePassResult result = RunSequencePass(
      tmp / "database.db", 15, tmp / "work", empty, SequencePassOptions());
  ASSERT_TRUE(result.ran) << result.note;
  EXPECT_EQ(result.num_judged, 0u);
  EXPECT_EQ(result.num_removed, 0u);
  const ViewGraph input = ReadViewGraph(Database(tmp / "database.db"), 15);
  const ViewGraph cleaned =
      ReadViewGraph(Database(result.cleaned_database_path), 15);
  EXPECT_EQ(cleaned.Edges().size(), input.Edges().size());
  EXPECT_EQ(cleaned.Weight(1, 5), input.Weight(1, 5));
}

// Two streets' pieces (images 1-4 and 5-8, in frames a similarity apart)
// share 40 unique points and a facade pattern of 3 rows x 20 columns. Their
// verified pairs match the unique points truly (pair 4-5) and the pattern
// shifted by 1 to 6 columns (six pairs, one shift each): no similarity has
// 20% of the matched points, so the pairs cannot join the pieces. Inside
// each piece three pairs match the pattern 4 or 8 columns apart, which makes
// the pattern's points confusing. Each shifted pair proposes a join under
// which its photos should match unique points they do not; the true pair's
// join predicts only unique points it matches.
constexpr int kColumns = 20, kRows = 3, kUnique = 40;
constexpr int kNumPoints = kColumns * kRows + kUnique;

Eigen::Vector3d StreetPoint(int p) {
  if (p < kColumns * kRows) {
    return {2.5 * (p % kColumns), 10.0, -1.0 + (p / kColumns)};
  }
  std::mt19937 rng(p);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  return {15.0 * u(rng), 8.0 + 4.0 * u(rng), -1.5 + 3.0 * u(rng)};
}

int PatternPoint(int column, int row) { return row * kColumns + column; }

Rigid3d StreetCamera(int k) {
  Eigen::Matrix3d R;
  R << 1, 0, 0, 0, 0, -1, 0, 1, 0;
  const Eigen::Vector3d center(1.0 + 2.0 * ((k - 1) % 4), 0.0, 0.0);
  return Rigid3d(Eigen::Quaterniond(R), -(R * center));
}

// The similarity from the world to the second piece's frame.
Sim3d SecondFromWorld() {
  Sim3d s;
  s.scale = 2.0;
  s.rotation = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ());
  s.translation = Eigen::Vector3d(5.0, 3.0, 1.0);
  return s;
}

struct TwoStreets {
  std::vector<Reconstruction> pieces;
};

// `swap_names_5_6`: images 5 and 6 trade names (6 comes first in the name
// order).
TwoStreets WriteTwoStreetsDatabase(const std::string& path,
                                   bool swap_names_5_6 = false) {
  constexpr double kFocal = 800.0;
  DatabaseWriter writer(path);
  writer.WriteCamera(SimplePinholeCamera(1, 1024, 768, kFocal));
  TwoStreets streets;
  streets.pieces.resize(2);
  for (Reconstruction& piece : streets.pieces) {
    piece.cameras[1] = {1, 0, 1024, 768, {kFocal, 512.0, 384.0}};
  }
  const Sim3d second_from_world = SecondFromWorld();
  for (ImageId id = 1; id <= 8; ++id) {
    char name[32];
    const ImageId rank =
        swap_names_5_6 && (id == 5 || id == 6) ? 11 - id : id;
    std::snprintf(name, sizeof(name), "%06u.jpg", rank);
    writer.WriteImage({id, name, 1});
    const Rigid3d cam_from_world = StreetCamera(id);
    Keypoints keypoints(kNumPoints, 2);
    Image image;
    image.image_id = id;
    image.camera_id = 1;
    image.name = name;
    image.cam_from_world = id <= 4
                               ? cam_from_world
                               : second_from_world.TransformPose(cam_from_world);
    for (int p = 0; p < kNumPoints; ++p) {
      const Eigen::Vector3d x = cam_from_world * StreetPoint(p);
      const Eigen::Vector2d uv(kFocal * x.x() / x.z() + 512.0,
                               kFocal * x.y() / x.z() + 384.0);
      keypoints.row(p) << static_cast<float>(uv.x()),
          static_cast<float>(uv.y());
      image.points2D.push_back({uv, static_cast<Point3DId>(p + 1)});
    }
    writer.WriteKeypoints(id, keypoints);
    streets.pieces[id <= 4 ? 0 : 1].images[id] = image;
  }
  for (int piece = 0; piece < 2; ++piece) {
    for (int p = 0; p < kNumPoints; ++p) {
      Point3D point;
      point.xyz = piece == 0 ? StreetPoint(p) : second_from_world * StreetPoint(p);
      for (ImageId k = 1; k <= 4; ++k) {
        point.track.push_back({k + 4u * piece, static_cast<Point2DIdx>(p)});
      }
      streets.pieces[piece].points3D[p + 1] = point;
    }
  }
  auto write = [&](ImageId a, ImageId b, std::vector<FeatureMatch> matches) {
    TwoViewGeometry g;
    g.pair = ImagePair(a, b);
    g.config = static_cast<int>(TwoViewConfig::kCalibrated);
    g.inlier_matches = std::move(matches);
    writer.WriteTwoViewGeometry(g);
  };
  auto all_true = [] {
    std::vector<FeatureMatch> m;
    for (Point2DIdx p = 0; p < kNumPoints; ++p) m.push_back({p, p});
    return m;
  };
  auto pattern_shifted = [](int shift) {
    std::vector<FeatureMatch> m;
    for (int row = 0; row < kRows; ++row) {
      for (int column = 0; column + shift < kColumns; ++column) {
        m.push_back({static_cast<Point2DIdx>(PatternPoint(column, row)),
                     static_cast<Point2DIdx>(PatternPoint(column + shift, row))});
      }
    }
    return m;
  };
  auto unique_only = [] {
    std::vector<FeatureMatch> m;
    for (Point2DIdx p = kColumns * kRows; p < kNumPoints; ++p) m.push_back({p, p});
    return m;
  };
  for (ImageId first : {1u, 5u}) {
    for (ImageId k = first; k < first + 3; ++k) write(k, k + 1, all_true());
    write(first, first + 2, pattern_shifted(4));
    write(first + 1, first + 3, pattern_shifted(4));
    write(first, first + 3, pattern_shifted(8));
  }
  write(4, 5, unique_only());
  const std::vector<std::pair<ImagePair, int>> doppelgangers = {
      {ImagePair(1, 6), 1}, {ImagePair(1, 7), 2}, {ImagePair(1, 8), 3},
      {ImagePair(2, 6), 4}, {ImagePair(2, 7), 5}, {ImagePair(2, 8), 6}};
  for (const auto& [pair, shift] : doppelgangers) {
    write(pair.image_id1, pair.image_id2, pattern_shifted(shift));
  }
  writer.Close();
  return streets;
}

// Expects the joined chain of the two streets to hold all eight photos, the
// second piece's cameras where they stand in the first's frame.
void ExpectStreetsJoinedAtTruth(const SequencePassResult& joined) {
  ASSERT_EQ(joined.chain_models.size(), 1u);
  const Reconstruction& model = joined.chain_models[0];
  ASSERT_EQ(model.NumRegImages(), 8u);
  for (ImageId id = 5; id <= 8; ++id) {
    const Eigen::Vector3d truth = StreetCamera(id).Inverse().translation;
    EXPECT_LT((model.images.at(id).ProjectionCenter() - truth).norm(), 1e-3)
        << "image " << id;
  }
}

// The two streets' database in a temporary folder, their pieces as the
// chain's models, and the pass's options for them (the name order on, no
// join by conflict unless a test turns it on).
struct TwoStreetsPass {
  // `swap_names_5_6` as for WriteTwoStreetsDatabase.
  explicit TwoStreetsPass(bool swap_names_5_6 = false)
      : streets(WriteTwoStreetsDatabase(tmp / "database.db", swap_names_5_6)) {}

  TempDir tmp{"hisfm-sequence-pass"};
  TwoStreets streets;
  SequencePassOptions options = [] {
    SequencePassOptions o;
    o.sequence.mode = "on";
    o.join_by_conflict = false;
    return o;
  }();

  // Runs the pass with its work folder `name`.
  SequencePassResult Run(const std::string& name) const {
    const ChainReconstructor pieces = [&](const std::string&) {
      return streets.pieces;
    };
    return RunSequencePass(tmp / "database.db", 1, tmp / name, pieces,
                           options);
  }
};

TEST(SequencePass, PiecesJoinByTheConflictWithTheirUniquePoints) {
  TwoStreetsPass pass;
  SequencePassOptions& options = pass.options;
  // The link 4-5 alone would join them in the near round (the next test);
  // here the pieces stand for two streets that only the conflict can join.
  options.near_join_window = 0;
  const SequencePassResult apart = pass.Run("apart");
  EXPECT_FALSE(apart.ran);
  EXPECT_EQ(apart.num_joined, 0u);

  options.join_by_conflict = true;
  // One pair votes for each proposed join here, and each photo sees about
  // tens of the unique points.
  options.conflict_join.min_votes = 1;
  options.conflict_join.min_expected = 10;
  const SequencePassResult joined = pass.Run("joined");
  ASSERT_TRUE(joined.ran) << joined.note;
  EXPECT_EQ(joined.num_joined, 1u);
  EXPECT_EQ(joined.num_joined_by_conflict, 1u);
  ExpectStreetsJoinedAtTruth(joined);
  // The doppelganger pairs across the pieces are removed.
  const ViewGraph cleaned =
      ReadViewGraph(Database(joined.cleaned_database_path), 1);
  EXPECT_EQ(cleaned.Weight(1, 6), 0u);
  EXPECT_EQ(cleaned.Weight(2, 8), 0u);
  EXPECT_EQ(cleaned.Weight(4, 5), static_cast<size_t>(kUnique));
}

// The two pieces above lie on one unbroken stretch of the chain (the link
// 4-5 matches 40 unique points, not weak enough to break it). Through the
// link alone they join at the true similarity; within five places the
// doppelganger pairs 1-6, 1-7, 2-6 and 2-7 join the near pairs too, and as
// no similarity has most of their matched points, the near round refuses;
// a link that breaks the chain gives no near pair.
TEST(SequencePass, PiecesOfAnUnbrokenStretchJoinThroughTheirNearPairs) {
  TwoStreetsPass pass;
  SequencePassOptions& options = pass.options;
  options.near_join_window = 1;
  const SequencePassResult link = pass.Run("link");
  ASSERT_TRUE(link.ran) << link.note;
  EXPECT_EQ(link.num_joined, 1u);
  EXPECT_EQ(link.num_joined_near, 1u);
  EXPECT_EQ(link.ToJson()["joined_near"], 1u);
  ExpectStreetsJoinedAtTruth(link);

  options.near_join_window = 5;
  const SequencePassResult near = pass.Run("near");
  EXPECT_FALSE(near.ran);
  EXPECT_EQ(near.num_joined_near, 0u);

  options.near_join_window = 1;
  options.sequence.break_ratio = 0.5;  // 40 inliers against 100: a break
  const SequencePassResult broken = pass.Run("broken");
  EXPECT_EQ(broken.chain.num_breaks, 1u);
  EXPECT_FALSE(broken.ran);
  EXPECT_EQ(broken.num_joined_near, 0u);
}

// The two streets as one chain model that drifted between images 4 and 5:
// images 5-8 and their points stand in the frame `drift` maps the world to
// (their point ids moved past the first piece's).
Reconstruction DriftedChainModel(const TwoStreets& streets,
                                 const Sim3d& drift) {
  const Sim3d world_from_second = SecondFromWorld().Inverse();
  Reconstruction model = streets.pieces[0];
  constexpr Point3DId kOffset = 1000;
  for (auto [id, image] : streets.pieces[1].images) {
    image.cam_from_world =
        drift.TransformPose(world_from_second.TransformPose(image.cam_from_world));
    for (Point2D& point : image.points2D) point.point3D_id += kOffset;
    model.images[id] = image;
  }
  for (auto [id, point] : streets.pieces[1].points3D) {
    point.xyz = drift * (world_from_second * point.xyz);
    model.points3D[id + kOffset] = point;
  }
  return model;
}

// A drift of a few degrees and a metre or two.
Sim3d SmallDrift() {
  Sim3d s;
  s.scale = 1.1;
  s.rotation = Eigen::AngleAxisd(5.0 * M_PI / 180.0, Eigen::Vector3d::UnitZ());
  s.translation = Eigen::Vector3d(2.0, 1.0, 0.0);
  return s;
}

// The pass on the two streets' database with images 5 and 6 trading names
// (the order 1, 2, 3, 4, 6, 5, 7, 8: the closure 4-5 lies two places apart)
// and a chain model that drifted by `drift`, with a break window of
// `break_window`.
SequencePassResult RunOnDriftedLoop(const TwoStreetsPass& pass,
                                    const Sim3d& drift,
                                    SequencePassOptions options,
                                    const std::string& name,
                                    int break_window = 1) {
  options.sequence.break_window = break_window;
  options.conflict_join.min_votes = 1;
  options.conflict_join.min_expected = 10;
  const std::vector<Reconstruction> drifted = {
      DriftedChainModel(pass.streets, drift)};
  const ChainReconstructor chain = [&](const std::string&) { return drifted; };
  return RunSequencePass(pass.tmp / "database.db", 1, pass.tmp / name, chain,
                         options);
}

// A drifted chain: its closure 4-5 (the unique points, truly) lands far off
// in the chain's model and fails the transfer test, as do the six
// doppelgangers across the drift. Cut in the halves of the order (1-4 and
// 6, 5, 7, 8), the rejected pairs across propose joins; the closure's is the
// one whose photos match the unique points it predicts, and it is kept with
// its input matches, while the doppelgangers go.
TEST(SequencePass, ADriftedLoopKeepsTheClosureOfLeastConflict) {
  const TwoStreetsPass pass(/*swap_names_5_6=*/true);
  const SequencePassResult closed =
      RunOnDriftedLoop(pass, SmallDrift(), pass.options, "closed");
  ASSERT_TRUE(closed.ran) << closed.note;
  EXPECT_EQ(closed.num_joined, 0u);
  EXPECT_EQ(closed.num_loop_closures, 1u);
  EXPECT_EQ(closed.loop_closures, (std::vector<ImagePair>{ImagePair(4, 5)}));
  EXPECT_EQ(closed.ToJson()["loop_closures_kept"], 1u);
  const ViewGraph cleaned =
      ReadViewGraph(Database(closed.cleaned_database_path), 1);
  EXPECT_EQ(cleaned.Weight(4, 5), static_cast<size_t>(kUnique));
  EXPECT_EQ(cleaned.Weight(1, 6), 0u);
  EXPECT_EQ(cleaned.Weight(2, 8), 0u);
  EXPECT_EQ(cleaned.Weight(1, 2), static_cast<size_t>(kNumPoints));

  SequencePassOptions off = pass.options;
  off.close_loops_by_conflict = false;
  const SequencePassResult open =
      RunOnDriftedLoop(pass, SmallDrift(), off, "open");
  ASSERT_TRUE(open.ran) << open.note;
  EXPECT_EQ(open.num_loop_closures, 0u);
  EXPECT_TRUE(open.loop_closures.empty());
  EXPECT_EQ(ReadViewGraph(Database(open.cleaned_database_path), 1)
                .Weight(4, 5),
            0u);
  EXPECT_EQ(open.num_removed, closed.num_removed + 1);

  // Within the break window the pair is the chain's neighbour, no closure.
  EXPECT_EQ(RunOnDriftedLoop(pass, SmallDrift(), pass.options, "near", 2)
                .num_loop_closures,
            0u);
}

// A join that turns one half by 90 degrees maps a symmetric object's side
// onto its twin; it is no drift, and no closure is kept unless the bound is
// raised past it.
TEST(SequencePass, AJoinThatTurnsHalfTheLoopFarIsNoClosure) {
  const TwoStreetsPass pass(/*swap_names_5_6=*/true);
  const SequencePassResult turned =
      RunOnDriftedLoop(pass, SecondFromWorld(), pass.options, "turned");
  ASSERT_TRUE(turned.ran) << turned.note;
  EXPECT_EQ(turned.num_loop_closures, 0u);

  SequencePassOptions wide = pass.options;
  wide.loop_closure_max_rotation_deg = 100.0;
  EXPECT_EQ(
      RunOnDriftedLoop(pass, SecondFromWorld(), wide, "wide").num_loop_closures,
      1u);
}

// The two streets as one model in the world's frame, one 3D point for each
// street point, observed by all eight photos.
Reconstruction OneChainModel(const TwoStreets& streets) {
  const Sim3d world_from_second = SecondFromWorld().Inverse();
  Reconstruction model = streets.pieces[0];
  for (auto [id, image] : streets.pieces[1].images) {
    image.cam_from_world =
        world_from_second.TransformPose(image.cam_from_world);
    for (size_t k = 0; k < image.points2D.size(); ++k) {
      model.points3D.at(image.points2D[k].point3D_id)
          .track.push_back({id, static_cast<Point2DIdx>(k)});
    }
    model.images[id] = image;
  }
  return model;
}

// `model` moved into the frame that `to_frame` maps its world to.
Reconstruction InFrame(Reconstruction model, const Sim3d& to_frame) {
  for (auto& [id, image] : model.images) {
    image.cam_from_world = to_frame.TransformPose(image.cam_from_world);
  }
  for (auto& [id, point] : model.points3D) point.xyz = to_frame * point.xyz;
  return model;
}

// A long chain is reconstructed in overlapping segments, each by its own
// run on a database of its links alone (here each run returns the true
// model of its images in a frame of its own); the segments' models merge
// through their shared images into one model at the truth, and the pairs
// are judged against it as against one run's model.
TEST(SequencePass, ALongChainIsReconstructedInSegmentsThatMerge) {
  TwoStreetsPass pass;
  SequencePassOptions& options = pass.options;
  options.chain_segment_images = 5;
  options.chain_segment_overlap = 2;
  const Reconstruction truth = OneChainModel(pass.streets);
  // The segments run side by side (chain_segment_parallel_runs, 2 by
  // default), each on a database of its own.
  ASSERT_EQ(options.chain_segment_parallel_runs, 2);
  std::mutex mutex;
  std::vector<std::set<ImageId>> calls;
  std::set<std::string> databases;
  const ChainReconstructor segments = [&](const std::string& chain_db) {
    std::set<ImageId> images;
    for (const ImagePair& p : ReadViewGraph(Database(chain_db), 1).Pairs()) {
      images.insert({p.image_id1, p.image_id2});
    }
    std::set<ImageId> others;
    for (const auto& [id, image] : truth.images) {
      if (!images.count(id)) others.insert(id);
    }
    Reconstruction model = truth;
    RemoveImages(others, &model);
    {
      std::lock_guard<std::mutex> lock(mutex);
      calls.push_back(images);
      databases.insert(chain_db);
    }
    // Each run's model stands in a frame of its own.
    return std::vector<Reconstruction>{
        InFrame(model, images.count(1) ? Sim3d() : SecondFromWorld())};
  };
  const SequencePassResult result = RunSequencePass(
      pass.tmp / "database.db", 1, pass.tmp / "segments", segments, options);
  ASSERT_TRUE(result.ran) << result.note;
  // 8 images in segments of at most 5 sharing 2: images 1-5 and 4-8, each
  // run on a database of its own, removed after it.
  ASSERT_EQ(calls.size(), 2u);
  std::sort(calls.begin(), calls.end());
  EXPECT_EQ(calls[0], (std::set<ImageId>{1, 2, 3, 4, 5}));
  EXPECT_EQ(calls[1], (std::set<ImageId>{4, 5, 6, 7, 8}));
  EXPECT_EQ(databases.size(), 2u);
  for (const std::string& db : databases) EXPECT_FALSE(fs::exists(db)) << db;
  EXPECT_EQ(result.num_segments, 2u);
  EXPECT_EQ(result.ToJson()["segments"], 2u);
  EXPECT_EQ(result.num_models, 1u);
  ExpectStreetsJoinedAtTruth(result);
  const ViewGraph cleaned =
      ReadViewGraph(Database(result.cleaned_database_path), 1);
  EXPECT_EQ(cleaned.Weight(1, 6), 0u);
  EXPECT_EQ(cleaned.Weight(1, 2), static_cast<size_t>(kNumPoints));

  // Segments of 0 images: one run on every link.
  calls.clear();
  options.chain_segment_images = 0;
  const SequencePassResult whole = RunSequencePass(
      pass.tmp / "database.db", 1, pass.tmp / "whole", segments, options);
  ASSERT_TRUE(whole.ran) << whole.note;
  ASSERT_EQ(calls.size(), 1u);
  EXPECT_EQ(calls[0].size(), 8u);
  EXPECT_EQ(whole.num_segments, 1u);
  EXPECT_EQ(whole.num_removed, result.num_removed);

  // One after another: the same chain and the same verdicts.
  calls.clear();
  options.chain_segment_images = 5;
  options.chain_segment_parallel_runs = 1;
  const SequencePassResult serial = RunSequencePass(
      pass.tmp / "database.db", 1, pass.tmp / "serial", segments, options);
  ASSERT_TRUE(serial.ran) << serial.note;
  EXPECT_EQ(calls.size(), 2u);
  EXPECT_EQ(serial.num_models, 1u);
  EXPECT_EQ(serial.num_removed, result.num_removed);
  EXPECT_EQ(serial.num_registered, result.num_registered);
  options.chain_segment_parallel_runs = 0;
  EXPECT_THROW(options.Check(), Error);
}

// A segment whose run fails leaves the others: their models are still the
// chain's, and only when every run fails is the chain not reconstructed.
TEST(SequencePass, AFailingSegmentLeavesTheOthers) {
  TwoStreetsPass pass;
  SequencePassOptions& options = pass.options;
  options.chain_segment_images = 5;
  options.chain_segment_overlap = 2;
  options.require_one_model = false;
  const Reconstruction truth = OneChainModel(pass.streets);
  std::atomic<int> calls{0};
  // The segment of images 4-8 fails (the segments run side by side).
  const ChainReconstructor second_fails = [&](const std::string& chain_db) {
    ++calls;
    if (ReadViewGraph(Database(chain_db), 1).Weight(7, 8) > 0) {
      throw Error("no good initial image pair");
    }
    Reconstruction model = truth;
    RemoveImages({6, 7, 8}, &model);
    return std::vector<Reconstruction>{model};
  };
  const SequencePassResult result = RunSequencePass(
      pass.tmp / "database.db", 1, pass.tmp / "one", second_fails, options);
  ASSERT_TRUE(result.ran) << result.note;
  EXPECT_EQ(calls.load(), 2);
  EXPECT_EQ(result.num_registered, 5u);

  calls = 0;
  const ChainReconstructor failing = [&](const std::string&) {
    ++calls;
    throw Error("no good initial image pair");
    return std::vector<Reconstruction>();
  };
  const SequencePassResult none = RunSequencePass(
      pass.tmp / "database.db", 1, pass.tmp / "none", failing, options);
  EXPECT_EQ(calls.load(), 2);
  EXPECT_FALSE(none.ran);
  EXPECT_NE(none.note.find("no good initial image pair"), std::string::npos)
      << none.note;
}

}  // namespace
}  // namespace hisfm
