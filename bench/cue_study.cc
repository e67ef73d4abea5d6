// Measures the built-in verifier's evidence on labelled image pairs and
// reports how well each cue separates true pairs from doppelgangers (AUC).
#include <CLI/CLI.hpp>
#include <algorithm>
#include <fstream>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <numeric>
#include <set>
#include <sstream>

#include "hisfm/graph/view_graph.h"
#include "hisfm/io/database.h"
#include "hisfm/io/model.h"
#include "hisfm/synth/synthetic_dataset.h"
#include "hisfm/util/timer.h"
#include "hisfm/verify/multiview_verifier.h"
#include "hisfm/verify/relative_pose.h"
#include "hisfm/verify/triangulation.h"
#include "hisfm/verify/view_graph_reader.h"

using namespace hisfm;

namespace {

// Area under the ROC curve: the probability that a random positive scores
// above a random negative (ties count half).
double Auc(std::vector<double> pos, std::vector<double> neg) {
  if (pos.empty() || neg.empty()) return -1;
  std::sort(neg.begin(), neg.end());
  double sum = 0;
  for (const double p : pos) {
    const auto lo = std::lower_bound(neg.begin(), neg.end(), p);
    const auto hi = std::upper_bound(neg.begin(), neg.end(), p);
    sum += (lo - neg.begin()) + 0.5 * (hi - lo);
  }
  return sum / (static_cast<double>(pos.size()) * neg.size());
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app("Built-in verifier evidence on labelled pairs");
  std::string database_path, labels_path, output_path;
  app.add_option("--database_path", database_path)->required();
  std::string pair_labels_path, bridges_path;
  auto* labels_option = app.add_option(
      "--labels", labels_path,
      "Lines 'id1 id2 label' (1 true, 0 doppelganger, other: skipped)");
  app.add_option("--pair_labels", pair_labels_path,
                 "A synthetic scene's pair_labels.txt instead: a pair is true "
                 "if at least half its inliers are, a doppelganger if its "
                 "doppelganger inliers outnumber the true ones")
      ->excludes(labels_option);
  app.add_option("--bridges_of", bridges_path,
                 "A view_graph.json: only its bridges (skeleton and rejected)");
  auto* output_option =
      app.add_option("--output", output_path, "TSV of every judged pair");
  std::string reference_path;
  app.add_option("--reference", reference_path,
                 "Ground-truth model: adds pose errors of models and joins");
  double radius = 3.0, max_scale = 2.0, max_angle = 40.0;
  app.add_option("--max_scale_change", max_scale);
  app.add_option("--max_view_angle", max_angle);
  app.add_option("--radius", radius, "Keypoint radius (pixels)");
  bool triplets_only = false;
  app.add_flag(
      "--triplets_only", triplets_only,
      "Only the triangle cues, translation cone and rotation loop (no edge "
      "test): TSV columns id1 id2 label inliers triplet_err num_triplets "
      "rot_err dir_err rotation_loop_err");
  int max_triplets = 10;
  app.add_option("--max_triplets", max_triplets,
                 "Third images per pair, strongest first (up to this many)")
      ->check(CLI::PositiveNumber);
  std::vector<ImageId> debug_pairs;
  app.add_option("--debug_pair", debug_pairs, "id1 id2: print its models");
  CLI11_PARSE(app, argc, argv);
  if (triplets_only && output_option->count() == 0) {
    std::cerr << "error: --triplets_only needs --output\n";
    return 1;
  }

  Database database(database_path);
  const ViewGraph graph = ReadViewGraph(database, 15);
  std::map<ImagePair, int> labels;
  if (!labels_path.empty()) {
    std::ifstream in(labels_path);
    ImageId a, b;
    int l;
    while (in >> a >> b >> l) labels[ImagePair(a, b)] = l;
  } else if (!pair_labels_path.empty()) {
    std::map<std::string, ImageId> ids;
    for (const DatabaseImage& im : database.ReadImages()) ids[im.name] = im.image_id;
    for (const PairLabel& l : ReadPairLabels(pair_labels_path)) {
      if (!ids.count(l.name1) || !ids.count(l.name2)) {
        std::cerr << "error: " << pair_labels_path << " names " << l.name1
                  << " or " << l.name2 << ", not in the database\n";
        return 1;
      }
      labels[ImagePair(ids.at(l.name1), ids.at(l.name2))] =
          2 * l.num_true >= l.num_inliers ? 1 : (l.IsDoppelganger() ? 0 : -1);
    }
  } else {
    std::cerr << "error: --labels or --pair_labels is required\n";
    return 1;
  }
  if (!bridges_path.empty()) {
    std::ifstream in(bridges_path);
    const nlohmann::json view_graph = nlohmann::json::parse(in);
    std::set<ImagePair> bridges;
    for (const char* list : {"skeleton_bridges", "rejected_bridges"}) {
      for (const nlohmann::json& b : view_graph.at(list)) {
        bridges.insert(ImagePair(b.at("image_id1").get<ImageId>(),
                                 b.at("image_id2").get<ImageId>()));
      }
    }
    for (auto it = labels.begin(); it != labels.end();) {
      it = bridges.count(it->first) ? std::next(it) : labels.erase(it);
    }
  }
  MultiViewVerifierOptions verifier_options;
  verifier_options.geometry.keypoint_radius_px = radius;
  verifier_options.edge_test.visibility.max_scale_change = max_scale;
  verifier_options.edge_test.visibility.max_view_angle_deg = max_angle;
  verifier_options.edge_test.record_missing = !debug_pairs.empty();
  MultiViewVerifier verifier(database, graph, verifier_options);
  Reconstruction reference;
  if (!reference_path.empty()) reference = ReadModel(reference_path);
  // Angle (degrees) between a model's relative pose b_from_a and the truth.
  const auto pose_error = [&](ImageId a, ImageId b, const Rigid3d& b_from_a,
                              double* rot, double* dir) {
    const Rigid3d ta = reference.images.at(a).cam_from_world;
    const Rigid3d tb = reference.images.at(b).cam_from_world;
    const Rigid3d truth = tb * ta.Inverse();
    *rot = truth.rotation.angularDistance(b_from_a.rotation) * 180 / M_PI;
    const double c = truth.translation.normalized().dot(
        b_from_a.translation.normalized());
    *dir = std::acos(std::clamp(c, -1.0, 1.0)) * 180 / M_PI;
  };
  const auto print_model = [&](const LocalModel& m) {
    if (!reference.images.empty() && m.images.size() == 3) {
      // Ground-truth check of the model's two-view predictions into view 2.
      const auto& iv = verifier.cache().Image(m.images[0]);
      const auto& iu = verifier.cache().Image(m.images[2]);
      const auto vw = verifier.cache().Pair(m.images[0], m.images[1]);
      const Image& gv = reference.images.at(m.images[0]);
      const Image& gu = reference.images.at(m.images[2]);
      std::map<Point3DId, Eigen::Vector2d> seen_in_u;
      for (const Point2D& p : gu.points2D) {
        if (p.point3D_id != kInvalidPoint3DId) seen_in_u[p.point3D_id] = p.xy;
      }
      int shown = 0;
      for (const FeatureMatch& mm : vw->matches) {
        if (shown >= 8) break;
        const Rigid3d poses[2] = {m.cam_from_model[0], m.cam_from_model[1]};
        const Eigen::Vector2d x[2] = {iv.normalized[mm.idx1], verifier.cache().Image(m.images[1]).normalized[mm.idx2]};
        const Eigen::Vector3d X = TriangulateMultiView(poses, x, 2);
        const Eigen::Vector3d Y = m.cam_from_model[2] * X;
        const Eigen::Vector2d px = iu.camera.NormalizedToPixel(Y.hnormalized());
        const Point3DId pid = mm.idx1 < gv.points2D.size() ? gv.points2D[mm.idx1].point3D_id : kInvalidPoint3DId;
        auto it = seen_in_u.find(pid);
        std::cout << "    pred " << px.transpose() << " depth " << Y.z();
        if (it != seen_in_u.end()) std::cout << " truth kp " << it->second.transpose() << " dist " << (it->second - px).norm();
        else std::cout << " (not observed in view 2; pid " << (pid == kInvalidPoint3DId ? -1 : (long)pid) << ")";
        std::cout << " anykp " << iu.grid.AnyWithin(px) << "\n";
        ++shown;
      }
    }
    std::cout << "  model of " << m.images.empty() << " images:";
    for (size_t v = 0; v < m.images.size(); ++v) {
      std::cout << " " << m.images[v];
      if (!reference.images.empty() && v > 0) {
        double r, d;
        pose_error(m.images[0], m.images[v], m.cam_from_model[v], &r, &d);
        std::cout << " (rot " << r << " dir " << d << ")";
      }
    }
    std::cout << "; points " << m.points.size() << " checked " << m.num_checked
              << " found " << m.num_found << "\n";
  };
  // The triplets each image of a debugged pair tries on its side.
  std::vector<std::pair<ImageId, ImageId>> debug_egos;
  for (size_t k = 0; k + 1 < debug_pairs.size(); k += 2) {
    debug_egos.emplace_back(debug_pairs[k], debug_pairs[k + 1]);
    debug_egos.emplace_back(debug_pairs[k + 1], debug_pairs[k]);
  }
  for (const auto& [ego, other] : debug_egos) {
    const auto cands = SideNeighbours(
        verifier.RankingGraph(), ego, other,
        verifier_options.local_model.num_candidates,
        verifier_options.other_side_ratio);
    for (size_t x = 0; x < cands.size(); ++x) {
      for (size_t y = x + 1; y < cands.size(); ++y) {
        for (int ha = 0; ha < 2; ++ha) {
          for (int hc = 0; hc < 2; ++hc) {
            const LocalModel m = BuildTripletModel(verifier.cache(), ego, cands[x], cands[y], ha, hc, LocalModelOptions());
            if (m.empty()) continue;
            std::set<int> cells;
            const auto& im = verifier.cache().Image(ego);
            for (const uint32_t k : m.keypoints[0]) {
              cells.insert(static_cast<int>(im.pixels[k].x() / 64) * 1000 + static_cast<int>(im.pixels[k].y() / 64));
            }
            std::cout << "  triplet " << ego << " " << cands[x] << "/" << ha << " " << cands[y] << "/" << hc
                      << ": points " << m.points.size() << " cells " << cells.size() << " checked " << m.num_checked << " found " << m.num_found << "\n";
          }
        }
      }
    }
  }
  for (size_t k = 0; k + 1 < debug_pairs.size(); k += 2) {
    const ImagePair p(debug_pairs[k], debug_pairs[k + 1]);
    const EdgeEvidence& ev = verifier.Evaluate(p);
    std::cout << "pair " << p.image_id1 << " " << p.image_id2 << ": judged "
              << ev.judged << " hyp " << ev.hypothesis << " join " << ev.join_i
              << "/" << ev.join_j << " agree " << ev.agreement_i << "/"
              << ev.agreement_j << " unique " << ev.num_unique << " visible "
              << ev.num_visible << " found " << ev.num_found << "\n";
    if (!reference.images.empty()) {
      for (const auto& mp : ev.missing) {
        const Image& src = reference.images.at(mp.source);
        const Point3DId pid = mp.keypoint < src.points2D.size() ? src.points2D[mp.keypoint].point3D_id : kInvalidPoint3DId;
        std::cout << "    missing: source " << mp.source << " kp " << mp.keypoint << " -> image " << mp.target << " at " << mp.pixel.transpose();
        if (pid == kInvalidPoint3DId) { std::cout << " (no true point)\n"; continue; }
        const Image& tgt = reference.images.at(mp.target);
        bool seen = false;
        for (const Point2D& q : tgt.points2D) {
          if (q.point3D_id == pid) { std::cout << " truth: observed at " << q.xy.transpose() << " dist " << (q.xy - mp.pixel).norm() << "\n"; seen = true; break; }
        }
        if (!seen) std::cout << " truth: not observed there\n";
      }
    }
    const auto geometry = verifier.cache().Pair(p.image_id1, p.image_id2);
    for (const auto& h : geometry->hypotheses) {
      double r = 0, d = 0;
      if (!reference.images.empty()) {
        pose_error(p.image_id1, p.image_id2, h.cam2_from_cam1, &r, &d);
      }
      std::cout << "  hypothesis support " << h.num_support << " rot " << r
                << " dir " << d << "\n";
    }
    if (!reference.images.empty()) {
      const Rigid3d truth = reference.images.at(p.image_id2).cam_from_world *
                            reference.images.at(p.image_id1).cam_from_world.Inverse();
      const Rigid3d unit(truth.rotation, truth.translation.normalized());
      const Eigen::Matrix3d R = unit.rotation.toRotationMatrix();
      const Eigen::Matrix3d E = EssentialOfPose(unit);
      const auto& i1 = verifier.cache().Image(p.image_id1);
      const auto& i2 = verifier.cache().Image(p.image_id2);
      int support = 0, epipolar = 0;
      for (const FeatureMatch& m : geometry->matches) {
        support += SupportsPose(R, unit.translation, E, i1.normalized[m.idx1],
                                i2.normalized[m.idx2], 1.0 / i1.camera.MeanFocal(), 0.99996);
        epipolar += SupportsPose(R, unit.translation, E, i1.normalized[m.idx1],
                                i2.normalized[m.idx2], 2.0 / i1.camera.MeanFocal(), -2);
      }
      std::cout << "  truth: support " << support << " epipolar " << epipolar << " of " << geometry->matches.size() << "\n";
    }
    // Each image's strongest neighbours by the ranking weight, with their
    // weight to the pair's other image (the side split, local_model.h).
    const ViewGraph& ranking = verifier.RankingGraph();
    for (const auto& [ego, other] :
         {std::make_pair(p.image_id1, p.image_id2),
          std::make_pair(p.image_id2, p.image_id1)}) {
      std::cout << "  neighbours of " << ego << " (weight, to " << other
                << "):";
      for (const ImageId x : StrongestNeighbours(ranking, ego, 8, other)) {
        std::cout << " " << x << " (" << ranking.Weight(ego, x) << ", "
                  << ranking.Weight(other, x) << ")";
      }
      std::cout << "\n";
    }
    print_model(verifier.EgoModel(p.image_id1, p.image_id2));
    print_model(verifier.EgoModel(p.image_id2, p.image_id1));
  }
  // Direction from a's camera centre to b's, in a's frame, of the pair's
  // best-supported pose hypothesis; false without one.
  const auto direction = [&](ImageId a, ImageId b, Eigen::Vector3d* d,
                             Eigen::Matrix3d* b_from_a_rotation) {
    const ImagePair p(a, b);
    const auto g = verifier.cache().Pair(p.image_id1, p.image_id2);
    if (g->hypotheses.empty()) return false;
    Rigid3d pose = g->hypotheses[0].cam2_from_cam1;
    if (a != p.image_id1) pose = pose.Inverse();
    const Eigen::Matrix3d R = pose.rotation.toRotationMatrix();
    *d = -(R.transpose() * pose.translation).normalized();
    if (b_from_a_rotation) *b_from_a_rotation = R;
    return true;
  };
  // Angle (degrees) from d to the cone of non-negative combinations of u, w.
  const auto cone_angle = [](const Eigen::Vector3d& d, const Eigen::Vector3d& u,
                             const Eigen::Vector3d& w) {
    const auto angle = [](const Eigen::Vector3d& x, const Eigen::Vector3d& y) {
      return std::acos(std::clamp(x.normalized().dot(y.normalized()), -1.0,
                                  1.0)) * 180.0 / M_PI;
    };
    double best = std::min(angle(d, u), angle(d, w));
    if (u.cross(w).norm() > 1e-3) {
      Eigen::Matrix<double, 3, 2> A;
      A << u, w;
      const Eigen::Vector2d x = A.colPivHouseholderQr().solve(d);
      if (x(0) >= 0 && x(1) >= 0) best = std::min(best, angle(d, A * x));
    }
    return best;
  };
  // The pair (a, b)'s direction against the triangles it closes with third
  // images c matched to both: c - a = s1 u and c - b = s3 v (u, v from the
  // pairs (a, c), (b, c), v turned into a's frame by the pair's rotation)
  // put b - a in the cone of u and -v. Median angle over the strongest
  // triangles; -1 without any.
  // Also sets *rotation_error to the median angle (degrees) of the rotation
  // loop a -> b -> c -> a over the same triangles (the verifier's
  // CycleRotationErrorDeg; Zach et al. 2010).
  const auto triplet_error = [&](const ImagePair& p, int* count,
                                 double* rotation_error) {
    const ImageId a = p.image_id1, b = p.image_id2;
    Eigen::Vector3d d;
    Eigen::Matrix3d R_ba;
    *count = 0;
    *rotation_error = -1.0;
    if (!direction(a, b, &d, &R_ba)) return -1.0;
    std::vector<std::pair<uint32_t, ImageId>> thirds;
    for (const size_t e : graph.IncidentEdges(graph.IndexOf(a))) {
      const ImageId c = graph.OtherEnd(e, a);
      const uint32_t weight_bc = c == b ? 0 : graph.Weight(b, c);
      if (weight_bc == 0) continue;
      thirds.emplace_back(std::min(graph.Edges()[e].weight, weight_bc), c);
    }
    std::sort(thirds.rbegin(), thirds.rend());
    if (thirds.size() > static_cast<size_t>(max_triplets)) thirds.resize(max_triplets);
    std::vector<double> errors, rotation_errors;
    for (const auto& [w, c] : thirds) {
      Eigen::Vector3d u, v;
      if (!direction(a, c, &u, nullptr) || !direction(b, c, &v, nullptr)) continue;
      errors.push_back(cone_angle(d, u, -(R_ba.transpose() * v)));
      rotation_errors.push_back(verifier.CycleRotationErrorDeg({a, b, c}));
    }
    *count = static_cast<int>(errors.size());
    if (errors.empty()) return -1.0;
    const auto median = [](std::vector<double>& x) {
      std::nth_element(x.begin(), x.begin() + x.size() / 2, x.end());
      return x[x.size() / 2];
    };
    *rotation_error = median(rotation_errors);
    return median(errors);
  };
  if (triplets_only) {
    std::ofstream tout(output_path);
    tout << "id1\tid2\tlabel\tinliers\ttriplet_err\tnum_triplets\trot_err\t"
            "dir_err\trotation_loop_err\n";
    // Negated angles of the two cues, by inlier label and by pose
    // (right: rotation within 5 degrees, direction within 10).
    std::vector<double> cone[2][2], loop[2][2];
    for (const ViewGraphEdge& e : graph.Edges()) {
      auto it = labels.find(e.pair);
      if (it == labels.end() || (it->second != 0 && it->second != 1)) continue;
      int count = 0;
      double rotation_loop = -1;
      const double err = triplet_error(e.pair, &count, &rotation_loop);
      double rot = -1, dir = -1;
      const auto g = verifier.cache().Pair(e.pair.image_id1, e.pair.image_id2);
      if (reference.images.count(e.pair.image_id1) &&
          reference.images.count(e.pair.image_id2) && !g->hypotheses.empty()) {
        pose_error(e.pair.image_id1, e.pair.image_id2,
                   g->hypotheses[0].cam2_from_cam1, &rot, &dir);
      }
      if (err >= 0) {
        cone[0][it->second].push_back(-err);
        loop[0][it->second].push_back(-rotation_loop);
        if (rot >= 0) {
          const int right = rot < 5 && dir < 10;
          cone[1][right].push_back(-err);
          loop[1][right].push_back(-rotation_loop);
        }
      }
      tout << e.pair.image_id1 << '\t' << e.pair.image_id2 << '\t'
           << it->second << '\t' << e.weight << '\t' << err << '\t'
           << count << '\t' << rot << '\t' << dir << '\t' << rotation_loop
           << '\n';
    }
    const char* kBy[2] = {"by inlier label",
                          "by pose (rotation < 5 deg, direction < 10 deg)"};
    for (int by = 0; by < 2; ++by) {
      if (by == 1 && reference.images.empty()) break;
      std::cout << kBy[by] << ": " << cone[by][1].size() << " right, "
                << cone[by][0].size() << " wrong pairs with triangles; AUC "
                << "cone " << Auc(cone[by][1], cone[by][0]) << ", rotation loop "
                << Auc(loop[by][1], loop[by][0]) << "\n";
    }
    return 0;
  }
  std::ofstream out;
  if (!output_path.empty()) {
    out.open(output_path);
    out << "id1\tid2\tlabel\tinliers\tjudged\tjoin_i\tjoin_j\tagree_i\t"
           "agree_j\tunique\tvisible\tfound\tmissing_fraction\tconsistent\t"
           "score\tdisplaced\tmodels_checked\tmodels_found\trel_burst\t"
           "rel_inliers\tview_angle\tbest_rot_err\n";
  }
  // Median angle (degrees) at which the pair's inliers are seen from its two
  // cameras under the hypothesis its test accepted (else the best one); -1
  // without a pose.
  const auto median_view_angle = [&](const ImagePair& p, int h) {
    const auto g = verifier.cache().Pair(p.image_id1, p.image_id2);
    if (g->hypotheses.empty()) return -1.0;
    const Rigid3d& pose = g->hypotheses[std::max(h, 0)].cam2_from_cam1;
    const Eigen::Matrix3d R = pose.rotation.toRotationMatrix();
    const Eigen::Vector3d c2 = -(R.transpose() * pose.translation);
    const auto& i1 = verifier.cache().Image(p.image_id1);
    const auto& i2 = verifier.cache().Image(p.image_id2);
    std::vector<double> angles;
    for (const FeatureMatch& m : g->matches) {
      double d1 = 0, d2 = 0;
      if (!RayDepths(R, pose.translation, i1.normalized[m.idx1],
                     i2.normalized[m.idx2], &d1, &d2) ||
          d1 <= 0 || d2 <= 0) {
        continue;
      }
      const Eigen::Vector3d X = d1 * i1.normalized[m.idx1].homogeneous();
      angles.push_back(TriangulationAngle(Eigen::Vector3d::Zero(), c2, X) *
                       180.0 / M_PI);
    }
    if (angles.empty()) return -1.0;
    std::nth_element(angles.begin(), angles.begin() + angles.size() / 2,
                     angles.end());
    return angles[angles.size() / 2];
  };
  // An edge's weight relative to the strongest edge of each of its images
  // (the smaller ratio).
  const auto relative = [](const ViewGraph& g, const ImagePair& p) {
    const auto best = [&](ImageId id) {
      const auto e = StrongestEdges(g, g.IndexOf(id), 1);
      return e.empty() ? 1.0 : static_cast<double>(g.Edges()[e[0]].weight);
    };
    const double w = g.Weight(p.image_id1, p.image_id2);
    return std::min(w / best(p.image_id1), w / best(p.image_id2));
  };
  // Rotation error (degrees) of the pair's best-supported pose hypothesis
  // against the reference (what a reconstruction would use); -1 without a
  // reference or a pose.
  const auto best_rotation_error = [&](const ImagePair& p) {
    const auto g = verifier.cache().Pair(p.image_id1, p.image_id2);
    if (reference.images.empty() || g->hypotheses.empty() ||
        !reference.images.count(p.image_id1) ||
        !reference.images.count(p.image_id2)) {
      return -1.0;
    }
    double rot = 0, dir = 0;
    pose_error(p.image_id1, p.image_id2, g->hypotheses[0].cam2_from_cam1, &rot,
               &dir);
    return rot;
  };
  std::vector<double> pos, neg;
  int silent[2] = {0, 0};
  Timer timer;
  for (const ViewGraphEdge& e : graph.Edges()) {
    auto it = labels.find(e.pair);
    if (it == labels.end() || (it->second != 0 && it->second != 1)) continue;
    const EdgeEvidence& ev = verifier.Evaluate(e.pair);
    const double score = verifier.ScoreOf(e.pair);
    if (!ev.judged) ++silent[it->second];
    (it->second ? pos : neg).push_back(score);
    if (out) {
      out << e.pair.image_id1 << '\t' << e.pair.image_id2 << '\t'
          << it->second << '\t' << e.weight << '\t' << ev.judged << '\t'
          << ev.join_i << '\t' << ev.join_j << '\t' << ev.agreement_i << '\t'
          << ev.agreement_j << '\t' << ev.num_unique << '\t'
          << ev.num_visible << '\t' << ev.num_found << '\t'
          << ev.MissingFraction() << '\t' << ev.num_consistent << '\t'
          << score << '\t' << ev.num_found_displaced << '\t'
          << ev.models_checked << '\t' << ev.models_found << '\t'
          << verifier.Features(e.pair).relative_burstiness << '\t'
          << relative(graph, e.pair) << '\t'
          << median_view_angle(e.pair, ev.hypothesis) << '\t'
          << best_rotation_error(e.pair) << '\n';
    }
  }
  std::cout << "pairs: " << pos.size() << " true, " << neg.size()
            << " false; silent " << silent[1] << " true, " << silent[0]
            << " false; AUC(score) " << Auc(pos, neg) << "; "
            << timer.ElapsedSeconds() << " s\n";
  return 0;
}
