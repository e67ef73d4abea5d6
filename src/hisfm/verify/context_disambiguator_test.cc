#include "hisfm/verify/context_disambiguator.h"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <map>
#include <random>
#include <set>

#include "hisfm/graph/union_find.h"
#include "hisfm/io/database_writer.h"
#include "hisfm/io/model.h"
#include "hisfm/util/error.h"
#include "hisfm/util/test_util.h"
#include "hisfm/verify/camera_projection.h"
#include "hisfm/verify/street_test_scene.h"
#include "hisfm/verify/view_graph_reader.h"

namespace hisfm {
namespace {

// ---------------------------------------------------------------------------
// Synthetic scene: fronto-parallel photos taken along a textured wall that
// carries two identical posters 20 units apart. Photos that see poster 1 are
// matched to photos that see poster 2 on the poster only (doppelgangers).

constexpr double kPixelsPerUnit = 106.7;  // 10 x 7.5 units -> 1067 x 800 px

struct WallPoint {
  Eigen::Vector2d xy;
  int twin = -1;  // index of the identical point on the other poster
};

struct SyntheticScene {
  std::vector<WallPoint> points;
  std::vector<double> centers;  // camera centre x per image (id = index + 1)
  std::set<ImagePair> doppelgangers;
  std::vector<ViewGraphEdge> edges;
};

SyntheticScene WriteSyntheticScene(const std::string& db_path, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0, 1);
  SyntheticScene s;
  for (int k = 0; k < 40 * 7.5 * 12; ++k) {
    s.points.push_back({Eigen::Vector2d(40 * u(rng), 7.5 * u(rng)), -1});
  }
  const size_t poster1 = s.points.size();
  for (int k = 0; k < 1080; ++k) {
    s.points.push_back(
        {Eigen::Vector2d(8 + 4 * u(rng), 1.5 + 4.5 * u(rng)), -1});
  }
  for (size_t k = poster1; k < poster1 + 1080; ++k) {
    const int twin = static_cast<int>(s.points.size());
    s.points.push_back({s.points[k].xy + Eigen::Vector2d(20, 0), int(k)});
    s.points[k].twin = twin;
  }
  for (int k = 0; k <= 20; ++k) s.centers.push_back(5 + 1.5 * k);

  DatabaseWriter writer(db_path);
  writer.WriteCamera(SimplePinholeCamera(1, 1067, 800, 800));

  // keypoint index of each wall point per image (-1: not detected).
  std::vector<std::vector<int>> kp_of(s.centers.size());
  std::normal_distribution<double> noise(0, 0.5);
  for (size_t i = 0; i < s.centers.size(); ++i) {
    const ImageId id = static_cast<ImageId>(i + 1);
    writer.WriteImage({id, "im" + std::to_string(id) + ".jpg", 1});
    std::vector<Eigen::Vector2f> kps;
    kp_of[i].assign(s.points.size(), -1);
    for (size_t p = 0; p < s.points.size(); ++p) {
      const double x = s.points[p].xy.x() - (s.centers[i] - 5);
      if (x < 0 || x > 10 || u(rng) > 0.8) continue;
      kp_of[i][p] = static_cast<int>(kps.size());
      kps.emplace_back(x * kPixelsPerUnit + noise(rng),
                       s.points[p].xy.y() * kPixelsPerUnit + noise(rng));
    }
    Keypoints k(kps.size(), 2);
    for (size_t r = 0; r < kps.size(); ++r) k.row(r) = kps[r].transpose();
    writer.WriteKeypoints(id, k);
  }
  for (size_t a = 0; a < s.centers.size(); ++a) {
    for (size_t b = a + 1; b < s.centers.size(); ++b) {
      const bool sees_poster1 = s.centers[a] >= 7 && s.centers[a] <= 13;
      const bool sees_poster2 = s.centers[b] >= 27 && s.centers[b] <= 33;
      const bool doppelganger = sees_poster1 && sees_poster2;
      TwoViewGeometry g;
      g.pair = ImagePair(a + 1, b + 1);
      g.config = static_cast<int>(TwoViewConfig::kCalibrated);
      for (size_t p = 0; p < s.points.size(); ++p) {
        if (kp_of[a][p] < 0 || u(rng) > 0.8) continue;
        // True correspondence, or the twin on the other poster.
        int q = static_cast<int>(p);
        if (doppelganger) {
          if (s.points[p].twin < 0 || p >= poster1 + 1080) continue;
          q = s.points[p].twin;
        }
        if (kp_of[b][q] < 0) continue;
        g.inlier_matches.push_back({static_cast<Point2DIdx>(kp_of[a][p]),
                                    static_cast<Point2DIdx>(kp_of[b][q])});
      }
      if (g.inlier_matches.size() < 15) continue;
      writer.WriteTwoViewGeometry(g);
      s.edges.push_back(
          {g.pair, static_cast<uint32_t>(g.inlier_matches.size())});
      if (doppelganger) s.doppelgangers.insert(g.pair);
    }
  }
  writer.Close();
  return s;
}

// Kruskal over the bridges by descending weight (HiSfM Algorithm 1, first
// tree), taking a bridge if the scorer gives it at least 0.5.
struct KruskalResult {
  std::vector<ImagePair> met;
  std::vector<ImagePair> accepted;
  size_t num_components = 0;
};

KruskalResult RunKruskal(const ViewGraph& graph, const Communities& comm,
                         BridgeScorer& scorer) {
  std::vector<ViewGraphEdge> bridges;
  for (const ViewGraphEdge& e : graph.Edges()) {
    if (comm.Of(e.pair.image_id1) != comm.Of(e.pair.image_id2)) {
      bridges.push_back(e);
    }
  }
  std::stable_sort(bridges.begin(), bridges.end(),
                   [](const ViewGraphEdge& a, const ViewGraphEdge& b) {
                     return a.weight > b.weight;
                   });
  KruskalResult r;
  UnionFind uf(comm.NumCommunities());
  r.num_components = comm.NumCommunities();
  for (const ViewGraphEdge& e : bridges) {
    const CommunityId a = comm.Of(e.pair.image_id1);
    const CommunityId b = comm.Of(e.pair.image_id2);
    if (uf.Connected(a, b)) continue;
    r.met.push_back(e.pair);
    if (scorer.Score({e.pair})[0] >= 0.5) {
      uf.Union(a, b);
      r.accepted.push_back(e.pair);
      --r.num_components;
    }
  }
  return r;
}

TEST(DisambiguatorOptions, CheckRejectsBadValues) {
  DisambiguatorOptions o;
  EXPECT_NO_THROW(o.Check());
  o.max_scan_memory_mb = -1;
  EXPECT_THROW(o.Check(), Error);
  o = DisambiguatorOptions();
  o.grid_cells = 1;
  EXPECT_THROW(o.Check(), Error);
  o = DisambiguatorOptions();
  o.num_reference_pairs = 0;
  EXPECT_THROW(o.Check(), Error);
  o = DisambiguatorOptions();
  o.min_relative_coverage = 0;
  EXPECT_THROW(o.Check(), Error);
  o.min_relative_coverage = 1.5;
  EXPECT_THROW(o.Check(), Error);
  o = DisambiguatorOptions();
  o.min_distinctive_ratio = -0.1;
  EXPECT_THROW(o.Check(), Error);
  o = DisambiguatorOptions();
  o.distinctive_significance = 0;
  EXPECT_THROW(o.Check(), Error);
}

TEST(ContextDisambiguator, NeedsACompleteContext) {
  VerifierContext context;
  EXPECT_THROW(ContextDisambiguator d(context), Error);
}

TEST(ContextDisambiguator, RejectsSyntheticPosterDoppelgangers) {
  TempDir dir("hisfm-disamb");
  const SyntheticScene scene = WriteSyntheticScene(dir / "database.db", 42);
  ASSERT_FALSE(scene.doppelgangers.empty());
  Database db(dir / "database.db");
  const ViewGraph graph = ReadViewGraph(db, 15);
  const Communities comm = ComputeCommunities(graph, CommunityOptions());
  ASSERT_GT(comm.NumCommunities(), 2u);

  // Without verification, Kruskal takes a doppelganger: the scene is hard.
  AcceptAllScorer accept_all;
  const KruskalResult blind = RunKruskal(graph, comm, accept_all);
  size_t blind_false = 0;
  for (const ImagePair& p : blind.accepted) {
    blind_false += scene.doppelgangers.count(p);
  }
  ASSERT_GE(blind_false, 1u);

  ContextDisambiguator disambiguator(db, graph, comm);
  EXPECT_EQ(disambiguator.Name(), "context");
  // Every doppelganger scores below 0.5; true bridges between photos that
  // overlap by at least 70% score at least 0.5.
  for (const ImagePair& p : scene.doppelgangers) {
    if (comm.Of(p.image_id1) == comm.Of(p.image_id2)) continue;
    const BridgeEvidence ev = disambiguator.Evaluate(p);
    EXPECT_LT(ev.score, 0.5) << p.image_id1 << "-" << p.image_id2
                             << " relative " << ev.relative;
    EXPECT_GE(ev.score, 0.0);
  }
  for (const ViewGraphEdge& e : graph.Edges()) {
    const ImagePair& p = e.pair;
    if (comm.Of(p.image_id1) == comm.Of(p.image_id2)) continue;
    const double shift = std::abs(scene.centers[p.image_id1 - 1] -
                                  scene.centers[p.image_id2 - 1]);
    if (scene.doppelgangers.count(p) || shift > 3.0) continue;
    const BridgeEvidence ev = disambiguator.Evaluate(p);
    EXPECT_GE(ev.score, 0.5) << p.image_id1 << "-" << p.image_id2
                             << " relative " << ev.relative;
    EXPECT_LE(ev.score, 1.0);
  }
  // Verified Kruskal: no doppelganger, one tree over all communities.
  const KruskalResult verified = RunKruskal(graph, comm, disambiguator);
  for (const ImagePair& p : verified.accepted) {
    EXPECT_EQ(scene.doppelgangers.count(p), 0u)
        << "accepted doppelganger " << p.image_id1 << "-" << p.image_id2;
  }
  EXPECT_EQ(verified.num_components, 1u);
}

TEST(ContextDisambiguator, EvidenceIsSymmetricAndCached) {
  TempDir dir("hisfm-disamb");
  const SyntheticScene scene = WriteSyntheticScene(dir / "database.db", 7);
  Database db(dir / "database.db");
  const ViewGraph graph = ReadViewGraph(db, 15);
  const Communities comm = ComputeCommunities(graph, CommunityOptions());
  ContextDisambiguator d(db, graph, comm);
  const ImagePair p = *scene.doppelgangers.begin();
  const BridgeEvidence a = d.Evaluate(p);
  const BridgeEvidence b = d.Evaluate(ImagePair(p.image_id2, p.image_id1));
  EXPECT_EQ(a.cells1, b.cells1);
  EXPECT_EQ(a.cells2, b.cells2);
  EXPECT_DOUBLE_EQ(a.score, b.score);
  EXPECT_GT(d.ReferenceCells(p.image_id1), 0.0);
  EXPECT_NEAR(a.relative, std::min(a.relative1, a.relative2), 1e-12);
  const std::vector<double> scores = d.Score({p, p});
  ASSERT_EQ(scores.size(), 2u);
  EXPECT_DOUBLE_EQ(scores[0], a.score);
  EXPECT_THROW(d.Evaluate(ImagePair(1, 999)), Error);
}

// ---------------------------------------------------------------------------
// Real scenes (Yan et al., CVPR 2017): pairs are labelled with the reference
// model: a pair is true if at least 70% of its inliers agree with the
// reference (a keypoint's reference 3D point projects within 10 px of its
// match), false if fewer than 30% do, unlabelled otherwise.

std::map<ImagePair, int> LabelWithReference(const Database& db,
                                            const ViewGraph& graph,
                                            const Reconstruction& ref) {
  const Camera& rc = ref.cameras.begin()->second;
  const CameraProjection proj(rc.model_id, rc.width, rc.height, rc.params);
  std::map<ImagePair, int> label;
  for (const ViewGraphEdge& e : graph.Edges()) {
    const TwoViewGeometry g =
        db.ReadTwoViewGeometry(e.pair.image_id1, e.pair.image_id2);
    auto ia = ref.images.find(g.pair.image_id1);
    auto ib = ref.images.find(g.pair.image_id2);
    if (ia == ref.images.end() || ib == ref.images.end()) continue;
    int ok = 0, n = 0;
    for (const FeatureMatch& m : g.inlier_matches) {
      for (int dir = 0; dir < 2; ++dir) {
        const Image& S = dir == 0 ? ia->second : ib->second;
        const Image& T = dir == 0 ? ib->second : ia->second;
        const Point2DIdx is = dir == 0 ? m.idx1 : m.idx2;
        const Point2DIdx it = dir == 0 ? m.idx2 : m.idx1;
        if (is >= S.points2D.size() || it >= T.points2D.size()) continue;
        const Point3DId pid = S.points2D[is].point3D_id;
        if (pid == kInvalidPoint3DId) continue;
        const Eigen::Vector3d Y = T.cam_from_world * ref.points3D.at(pid).xyz;
        ++n;
        if (Y.z() > 0 && (proj.NormalizedToPixel(Y.hnormalized()) -
                          T.points2D[it].xy)
                                 .norm() < 10) {
          ++ok;
        }
      }
    }
    if (n < 10) continue;
    const double cons = static_cast<double>(ok) / n;
    if (cons >= 0.7) label[e.pair] = 1;
    if (cons < 0.3) label[e.pair] = 0;
  }
  return label;
}

void CheckRealScene(const std::string& scene) {
  const std::string db_path = SharedDataPath("yan2017/" + scene, "database.db");
  const std::string ref_path = SharedDataPath("yan2017/" + scene, "reference");
  if (db_path.empty() || ref_path.empty()) {
    GTEST_SKIP() << "shared data yan2017/" << scene
                 << " not found (set HISFM_DATA_DIR): " << SharedDataDir();
  }
  Database db(db_path);
  const ViewGraph graph = ReadViewGraph(db, 15);
  const Communities comm = ComputeCommunities(graph, CommunityOptions());
  const std::map<ImagePair, int> label =
      LabelWithReference(db, graph, ReadModel(ref_path));
  auto label_of = [&](const ImagePair& p) {
    auto it = label.find(p);
    return it == label.end() ? -1 : it->second;
  };

  // Unverified, the first tree takes a doppelganger.
  AcceptAllScorer accept_all;
  const KruskalResult blind = RunKruskal(graph, comm, accept_all);
  int blind_false = 0;
  for (const ImagePair& p : blind.accepted) blind_false += label_of(p) == 0;
  ASSERT_GE(blind_false, 1) << scene << ": the scene should fool Kruskal";

  ContextDisambiguator disambiguator(db, graph, comm);
  const KruskalResult verified = RunKruskal(graph, comm, disambiguator);
  const std::set<ImagePair> accepted(verified.accepted.begin(),
                                     verified.accepted.end());
  int met_false = 0;
  for (const ImagePair& p : verified.met) {
    const int l = label_of(p);
    if (l == 0) {
      ++met_false;
      EXPECT_EQ(accepted.count(p), 0u)
          << scene << ": doppelganger " << p.image_id1 << "-" << p.image_id2
          << " accepted";
    }
    if (l == 1) {
      EXPECT_EQ(accepted.count(p), 1u)
          << scene << ": true bridge " << p.image_id1 << "-" << p.image_id2
          << " rejected";
    }
  }
  EXPECT_GE(met_false, blind_false);
  EXPECT_EQ(verified.num_components, 1u) << scene;
}

// In a street of identical houses, doppelgangers cover the photos almost as
// well as true pairs; their lack of distinctive inliers gives them away.
TEST(ContextDisambiguator, DistinctiveCueRejectsStreetDoppelgangers) {
  TempDir dir("hisfm-disamb");
  const street_test::Scene scene =
      street_test::Write(dir / "database.db", {16, true, 7});
  Database db(dir / "database.db");
  const ViewGraph graph = ReadViewGraph(db, 15);
  const Communities comm = ComputeCommunities(graph, CommunityOptions());
  ContextDisambiguator with_cue(db, graph, comm);
  DisambiguatorOptions coverage_only;
  coverage_only.min_distinctive_ratio = 0;
  ContextDisambiguator without_cue(db, graph, comm, coverage_only);
  int num_pure = 0, num_pure_passing_coverage = 0, num_true = 0;
  for (const auto& [pair, shift] : scene.shift) {
    const BridgeEvidence ev = with_cue.Evaluate(pair);
    EXPECT_EQ(ev.score, std::min(ev.coverage_score, ev.distinctive_score));
    EXPECT_EQ(without_cue.Evaluate(pair).score, ev.coverage_score);
    if (shift == 0) {
      ++num_true;
      EXPECT_GT(ev.distinctive_score, 0.99) << pair.image_id1 << "-"
                                            << pair.image_id2;
    } else if (scene.true_fraction.at(pair) == 0.0 &&
               ev.image_distinctive_fraction * ev.num_inliers >= 5) {
      ++num_pure;
      num_pure_passing_coverage += ev.coverage_score >= 0.5;
      EXPECT_LT(ev.distinctive_score, 0.5) << pair.image_id1 << "-"
                                           << pair.image_id2;
      EXPECT_EQ(ev.num_distinctive, 0u);
      EXPECT_LT(ev.distinctive_p_value, 0.01);
    }
  }
  EXPECT_GE(num_true, 10);
  EXPECT_GE(num_pure, 10);
  // Coverage alone lets some of them through.
  EXPECT_GE(num_pure_passing_coverage, 1);
}

// The repeated test street (16 photos, seed 7) with its top-1 communities.
struct Street : street_test::Opened {
  Street() : Opened(7) {}
  Communities communities = ComputeCommunities(graph, CommunityOptions());
};

// Bridges are scored from what the tracks' read recorded of them, with the
// scores of their inliers read afresh (Evaluate); a pair that is not a
// bridge, and every bridge beyond the memory budget, is read when asked for.
TEST(ContextDisambiguator, RecordedBridgesScoreLikeTheirInliers) {
  Street street;
  Database& db = street.db;
  const ViewGraph& graph = street.graph;
  const Communities& comm = street.communities;
  std::vector<ImagePair> bridges, inside;
  for (const ViewGraphEdge& e : graph.Edges()) {
    (comm.Of(e.pair.image_id1) != comm.Of(e.pair.image_id2) ? bridges
                                                             : inside)
        .push_back(e.pair);
  }
  ASSERT_GE(bridges.size(), 20u);
  ASSERT_GE(inside.size(), 1u);
  ContextDisambiguator reading(db, graph, comm);
  std::vector<double> expected;
  size_t num_distinct_scores = 0;
  for (const ImagePair& p : bridges) {
    expected.push_back(reading.Evaluate(p).score);
    num_distinct_scores +=
        std::count(expected.begin(), expected.end(), expected.back()) == 1;
  }
  // Scores that could tell a miscount apart, on both cues.
  ASSERT_GE(num_distinct_scores, 10u);
  ASSERT_LT(*std::min_element(expected.begin(), expected.end()), 0.5);
  const double inside_score = reading.Evaluate(inside[0]).score;

  std::vector<ImagePair> asked = bridges;
  // Asked for in reverse and with a pair inside a community at the end.
  std::reverse(asked.begin(), asked.end());
  asked.push_back(inside[0]);
  // Budgets for all, none, and part of the bridges (the records of this
  // street take some tens of kB).
  size_t num_partial = 0;
  for (const double budget_mb : {1024.0, 0.0, 0.005, 0.01, 0.02, 0.04}) {
    for (const double distinctive_ratio : {0.5, 0.0}) {
      DisambiguatorOptions options;
      options.max_scan_memory_mb = budget_mb;
      options.min_distinctive_ratio = distinctive_ratio;
      ContextDisambiguator scanned(db, graph, comm, options);
      ContextDisambiguator reading_now(db, graph, comm, options);
      const std::vector<double> got = scanned.Score(asked);
      ASSERT_EQ(got.size(), asked.size());
      for (size_t k = 0; k < bridges.size(); ++k) {
        const double want = distinctive_ratio > 0
                                ? expected[k]
                                : reading_now.Evaluate(bridges[k]).score;
        EXPECT_DOUBLE_EQ(got[bridges.size() - 1 - k], want)
            << bridges[k].image_id1 << "-" << bridges[k].image_id2
            << ", budget " << budget_mb << ", ratio " << distinctive_ratio;
      }
      EXPECT_DOUBLE_EQ(got.back(), distinctive_ratio > 0
                                       ? inside_score
                                       : reading_now.Evaluate(inside[0]).score);
      const size_t from_scan = scanned.NumScoredFromScan();
      EXPECT_EQ(from_scan + scanned.NumScoredByReading(), asked.size());
      if (budget_mb == 1024) {
        EXPECT_EQ(from_scan, bridges.size());
      }
      if (budget_mb == 0) {
        EXPECT_EQ(from_scan, 0u);
      }
      num_partial += from_scan > 0 && from_scan < bridges.size();
    }
  }
  EXPECT_GE(num_partial, 2u);
  // A pair missing from the database is an error.
  ContextDisambiguator scanned(db, graph, comm);
  EXPECT_THROW(scanned.Score({bridges[0], ImagePair(1, 999)}), Error);
}

TEST(ContextDisambiguator, CupKruskalRejectsDoppelgangers) {
  CheckRealScene("cup");
}

TEST(ContextDisambiguator, BooksKruskalRejectsDoppelgangers) {
  CheckRealScene("books");
}

}  // namespace
}  // namespace hisfm
