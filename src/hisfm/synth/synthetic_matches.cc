#include "hisfm/synth/synthetic_matches.h"

#include <Eigen/Dense>
#include <algorithm>
#include <array>
#include <cmath>
#include <future>
#include <map>
#include <numeric>
#include <unordered_map>

#include "hisfm/synth/synth_random.h"
#include "hisfm/util/parallel.h"

namespace hisfm {
namespace {

// Symmetry elements need this many matches to be tried as a hypothesis.
constexpr size_t kMinHypothesisSupport = 5;
// Family scenes: an essential matrix wins over a fundamental matrix with at
// most 1 / this many more inliers (COLMAP's min_E_F_inlier_ratio).
constexpr double kMinEFInlierRatio = 0.95;
// Family scenes: the pair is PLANAR_OR_PANORAMIC if a homography explains
// more than this fraction of the kept matrix's inliers (COLMAP's
// max_H_inlier_ratio).
constexpr double kMaxHInlierRatio = 0.8;
// Family scenes: fundamental matrices are fitted to pairs of the largest
// this many groups of matches.
constexpr size_t kMaxFittedGroups = 3;
// Family scenes: refits of the best matrices to their inliers.
constexpr int kMaxLocalOptimisations = 3;
// Family scenes: images per parallel task of the covisibility search.
constexpr size_t kCovisibilityChunk = 16;
// Pairs matched and verified per parallel batch.
constexpr size_t kBatchSize = 1024;

Eigen::Matrix3d CrossMatrix(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

// Squared Sampson error of a correspondence under F (pixels^2).
double SquaredSampsonError(const Eigen::Matrix3d& F, const Eigen::Vector2d& x1,
                           const Eigen::Vector2d& x2) {
  const Eigen::Vector3d p1 = x1.homogeneous();
  const Eigen::Vector3d p2 = x2.homogeneous();
  const Eigen::Vector3d Fx1 = F * p1;
  const Eigen::Vector3d Ftx2 = F.transpose() * p2;
  const double num = p2.dot(Fx1);
  const double den = Fx1.x() * Fx1.x() + Fx1.y() * Fx1.y() +
                     Ftx2.x() * Ftx2.x() + Ftx2.y() * Ftx2.y();
  if (!(den > 0.0)) return std::numeric_limits<double>::infinity();
  return num * num / den;
}

struct Candidate {
  float cosine = -2.0f;
  uint32_t index = 0;
};

// Family scenes: pairs of images that see at least one common appearance
// (sorted, image ids).
std::vector<ImagePair> FindCovisiblePairs(const SyntheticScene& scene) {
  const size_t n = scene.images.size();
  std::vector<std::vector<uint32_t>> appearances(n);
  uint32_t max_appearance = 0;
  for (size_t i = 0; i < n; ++i) {
    for (const auto& [appearance, feature] : scene.images[i].appearance_index) {
      if (appearances[i].empty() || appearances[i].back() != appearance) {
        appearances[i].push_back(appearance);
      }
    }
    if (!appearances[i].empty()) {
      max_appearance = std::max(max_appearance, appearances[i].back());
    }
  }
  // Images seeing each appearance, in increasing order.
  std::vector<std::vector<uint32_t>> seen_by(
      static_cast<size_t>(max_appearance) + 1);
  for (uint32_t i = 0; i < n; ++i) {
    for (uint32_t appearance : appearances[i]) seen_by[appearance].push_back(i);
  }
  const size_t num_chunks = (n + kCovisibilityChunk - 1) / kCovisibilityChunk;
  std::vector<std::vector<ImagePair>> per_chunk(num_chunks);
  ParallelFor(num_chunks, scene.options.num_threads, [&](size_t chunk) {
    std::vector<uint32_t> stamp(n, 0);
    std::vector<uint32_t> partners;
    const size_t end = std::min(n, (chunk + 1) * kCovisibilityChunk);
    for (size_t i = chunk * kCovisibilityChunk; i < end; ++i) {
      partners.clear();
      for (uint32_t appearance : appearances[i]) {
        const std::vector<uint32_t>& images = seen_by[appearance];
        for (auto it = std::upper_bound(images.begin(), images.end(),
                                        static_cast<uint32_t>(i));
             it != images.end(); ++it) {
          if (stamp[*it] == i + 1) continue;
          stamp[*it] = static_cast<uint32_t>(i + 1);
          partners.push_back(*it);
        }
      }
      std::sort(partners.begin(), partners.end());
      for (uint32_t j : partners) {
        per_chunk[chunk].emplace_back(static_cast<ImageId>(i + 1),
                                      static_cast<ImageId>(j + 1));
      }
    }
  });
  std::vector<ImagePair> pairs;
  for (std::vector<ImagePair>& chunk : per_chunk) {
    pairs.insert(pairs.end(), chunk.begin(), chunk.end());
  }
  return pairs;
}

// Hartley's normalisation of 2D points: mean 0, mean distance sqrt(2).
Eigen::Matrix3d NormalisingTransform(const std::vector<Eigen::Vector2d>& x) {
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const Eigen::Vector2d& p : x) mean += p;
  mean /= static_cast<double>(x.size());
  double spread = 0.0;
  for (const Eigen::Vector2d& p : x) spread += (p - mean).norm();
  spread /= static_cast<double>(x.size());
  const double scale = spread > 0.0 ? std::sqrt(2.0) / spread : 1.0;
  Eigen::Matrix3d T;
  T << scale, 0, -scale * mean.x(), 0, scale, -scale * mean.y(), 0, 0, 1;
  return T;
}

// Least-squares fundamental matrix of correspondences in pixels
// (normalised eight-point algorithm, rank 2 enforced), normalised to unit
// Frobenius norm.
Eigen::Matrix3d FitFundamental(const std::vector<Eigen::Vector2d>& x1,
                               const std::vector<Eigen::Vector2d>& x2) {
  const Eigen::Matrix3d T1 = NormalisingTransform(x1);
  const Eigen::Matrix3d T2 = NormalisingTransform(x2);
  Eigen::Matrix<double, 9, 9> M = Eigen::Matrix<double, 9, 9>::Zero();
  for (size_t k = 0; k < x1.size(); ++k) {
    const Eigen::Vector3d a = T1 * x1[k].homogeneous();
    const Eigen::Vector3d b = T2 * x2[k].homogeneous();
    Eigen::Matrix<double, 9, 1> row;
    row << b.x() * a.x(), b.x() * a.y(), b.x(), b.y() * a.x(), b.y() * a.y(),
        b.y(), a.x(), a.y(), 1.0;
    M.selfadjointView<Eigen::Lower>().rankUpdate(row);
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 9, 9>> solver(
      M.selfadjointView<Eigen::Lower>());
  const Eigen::Matrix<double, 9, 1> f = solver.eigenvectors().col(0);
  Eigen::Matrix3d F;
  F << f(0), f(1), f(2), f(3), f(4), f(5), f(6), f(7), f(8);
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(
      F, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Vector3d sigma = svd.singularValues();
  sigma(2) = 0.0;
  F = T2.transpose() * svd.matrixU() * sigma.asDiagonal() *
      svd.matrixV().transpose() * T1;
  const double norm = F.norm();
  return norm > 0.0 ? Eigen::Matrix3d(F / norm) : F;
}

// Least-squares homography x2 ~ H x1 of correspondences in pixels
// (normalised direct linear transform).
Eigen::Matrix3d FitHomography(const std::vector<Eigen::Vector2d>& x1,
                              const std::vector<Eigen::Vector2d>& x2) {
  const Eigen::Matrix3d T1 = NormalisingTransform(x1);
  const Eigen::Matrix3d T2 = NormalisingTransform(x2);
  Eigen::Matrix<double, 9, 9> M = Eigen::Matrix<double, 9, 9>::Zero();
  for (size_t k = 0; k < x1.size(); ++k) {
    const Eigen::Vector3d a = T1 * x1[k].homogeneous();
    const Eigen::Vector3d b = T2 * x2[k].homogeneous();
    Eigen::Matrix<double, 9, 1> row;
    row << 0, 0, 0, -a.x(), -a.y(), -1, b.y() * a.x(), b.y() * a.y(), b.y();
    M.selfadjointView<Eigen::Lower>().rankUpdate(row);
    row << a.x(), a.y(), 1, 0, 0, 0, -b.x() * a.x(), -b.x() * a.y(), -b.x();
    M.selfadjointView<Eigen::Lower>().rankUpdate(row);
  }
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 9, 9>> solver(
      M.selfadjointView<Eigen::Lower>());
  const Eigen::Matrix<double, 9, 1> h = solver.eigenvectors().col(0);
  Eigen::Matrix3d H;
  H << h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7), h(8);
  return T2.inverse() * H * T1;
}

// Number of correspondences whose transfer error |H x1 - x2| is within
// max_error (COLMAP's homography residual).
size_t CountHomographyInliers(const Eigen::Matrix3d& H,
                              const std::vector<Eigen::Vector2d>& x1,
                              const std::vector<Eigen::Vector2d>& x2,
                              double max_sq_error, std::vector<bool>* mask) {
  mask->assign(x1.size(), false);
  size_t count = 0;
  for (size_t m = 0; m < x1.size(); ++m) {
    const Eigen::Vector3d p = H * x1[m].homogeneous();
    if (!(std::abs(p.z()) > 1e-12)) continue;
    if ((p.hnormalized() - x2[m]).squaredNorm() <= max_sq_error) {
      (*mask)[m] = true;
      ++count;
    }
  }
  return count;
}

// Number of correspondences within `max_sq_error` (squared Sampson error)
// of F, and their mask.
size_t CountInliers(const Eigen::Matrix3d& F,
                    const std::vector<Eigen::Vector2d>& x1,
                    const std::vector<Eigen::Vector2d>& x2,
                    double max_sq_error, std::vector<bool>* mask) {
  mask->assign(x1.size(), false);
  size_t count = 0;
  for (size_t m = 0; m < x1.size(); ++m) {
    if (SquaredSampsonError(F, x1[m], x2[m]) <= max_sq_error) {
      (*mask)[m] = true;
      ++count;
    }
  }
  return count;
}

// The essential matrix, its F and the unit-baseline pose of hypothesis k.
struct EssentialHypothesis {
  Eigen::Matrix3d E = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d F = Eigen::Matrix3d::Zero();
  Rigid3d pose;
  bool valid = false;
};

EssentialHypothesis MakeEssentialHypothesis(const SyntheticScene& scene,
                                            const ImagePair& pair, int k) {
  EssentialHypothesis h;
  const Rigid3d pose =
      SynthHypothesisPose(scene, pair.image_id1, pair.image_id2, k);
  const double baseline = pose.translation.norm();
  if (baseline < 1e-9) return h;
  const Eigen::Matrix3d K_inv = scene.K.inverse();
  h.pose = Rigid3d(pose.rotation, pose.translation / baseline);
  h.E = CrossMatrix(h.pose.translation) * pose.rotation.toRotationMatrix();
  h.F = K_inv.transpose() * h.E * K_inv;
  h.valid = true;
  return h;
}

// A key of a symmetry element that is the same for every element with the
// same rotation about z and a translation along the same line (rounded).
std::array<int64_t, 4> ShiftDirection(const Rigid3d& g) {
  const Eigen::Matrix3d R = g.rotation.toRotationMatrix();
  Eigen::Vector3d t = g.translation;
  const double norm = t.norm();
  if (norm > 1e-9) t /= norm;
  // One sign per line.
  for (int i = 0; i < 3; ++i) {
    if (std::abs(t(i)) > 1e-6) {
      if (t(i) < 0) t = -t;
      break;
    }
  }
  return {std::llround(std::atan2(R(1, 0), R(0, 0)) * 1e3),
          std::llround(t.x() * 1e3), std::llround(t.y() * 1e3),
          std::llround(t.z() * 1e3)};
}

// The essential matrix closest (Frobenius) to K^T F K, and its F.
EssentialHypothesis NearestEssential(const Eigen::Matrix3d& K,
                                     const Eigen::Matrix3d& F) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(
      K.transpose() * F * K, Eigen::ComputeFullU | Eigen::ComputeFullV);
  EssentialHypothesis h;
  h.E = svd.matrixU() * Eigen::Vector3d(1, 1, 0).asDiagonal() *
        svd.matrixV().transpose();
  const Eigen::Matrix3d K_inv = K.inverse();
  h.F = K_inv.transpose() * h.E * K_inv;
  h.valid = true;
  return h;
}

// Direct verification of a family scene's pair, imitating COLMAP's
// two-view geometry estimation (see the header).
SynthVerification VerifyFamilyMatches(const SyntheticScene& scene,
                                      const SynthPairMatches& matches) {
  const SynthOptions& options = scene.options;
  SynthVerification result;
  result.geometry.pair = matches.pair;
  const size_t num_matches = matches.matches.size();
  if (num_matches == 0) return result;
  const SynthImage& image1 = scene.images.at(matches.pair.image_id1 - 1);
  const SynthImage& image2 = scene.images.at(matches.pair.image_id2 - 1);
  std::vector<Eigen::Vector2d> x1(num_matches), x2(num_matches);
  for (size_t m = 0; m < num_matches; ++m) {
    x1[m] = image1.features[matches.matches[m].idx1].xy.cast<double>();
    x2[m] = image2.features[matches.matches[m].idx2].xy.cast<double>();
  }
  const double max_sq_error = options.max_error * options.max_error;

  // Groups of matches with one label and one kind of point (repeated or
  // not): each group is consistent with one epipolar geometry.
  std::map<std::pair<int, bool>, std::vector<size_t>> groups;
  std::map<int, size_t> support;
  for (size_t m = 0; m < num_matches; ++m) {
    const int label = matches.labels[m];
    if (label == kOutlierMatchLabel) continue;
    const uint32_t point = image1.features[matches.matches[m].idx1].point_index;
    groups[{label, scene.layout.points[point].on_object}].push_back(m);
    if (label != 0) ++support[label];
  }

  // Essential matrices: the true geometry and every supported symmetry.
  std::vector<int> hypotheses = {0};
  for (const auto& [label, count] : support) {
    if (count >= kMinHypothesisSupport) hypotheses.push_back(label);
  }
  std::vector<bool> mask, best_e_mask;
  size_t best_e_count = 0;
  EssentialHypothesis best_e;
  for (int k : hypotheses) {
    const EssentialHypothesis h = MakeEssentialHypothesis(scene, matches.pair, k);
    if (!h.valid) continue;
    const size_t count = CountInliers(h.F, x1, x2, max_sq_error, &mask);
    if (count > best_e_count || !best_e.valid) {
      best_e_count = count;
      best_e_mask = mask;
      best_e = h;
      result.hypothesis = k;
    }
  }

  // Fundamental matrices fitted to the union of two of the largest groups
  // (and of all of them): what RANSAC finds when several geometries share
  // epipolar lines, e.g. the copies of a planar facade along a street.
  std::vector<const std::vector<size_t>*> largest;
  for (const auto& [key, members] : groups) {
    if (members.size() >= kMinHypothesisSupport) largest.push_back(&members);
  }
  std::stable_sort(largest.begin(), largest.end(),
                   [](const std::vector<size_t>* a, const std::vector<size_t>* b) {
                     return a->size() > b->size();
                   });
  if (largest.size() > kMaxFittedGroups) largest.resize(kMaxFittedGroups);
  std::vector<std::vector<const std::vector<size_t>*>> unions;
  for (size_t a = 0; a < largest.size(); ++a) {
    for (size_t b = a + 1; b < largest.size(); ++b) {
      unions.push_back({largest[a], largest[b]});
    }
  }
  if (largest.size() > 2) unions.push_back(largest);
  // And to every group whose symmetry shifts along one direction (the
  // copies along one facade: a planar facade's copies share epipolar lines
  // with the true geometry), with and without the true matches of repeated
  // content, and to every group.
  std::map<std::array<int64_t, 4>, std::vector<const std::vector<size_t>*>>
      directions;
  std::vector<const std::vector<size_t>*> all;
  const std::vector<size_t>* true_repeated = nullptr;
  for (const auto& [key, members] : groups) {
    if (key.first == 0) {
      if (key.second) true_repeated = &members;
    } else if (key.second) {
      directions[ShiftDirection(scene.layout.symmetry.Transform(key.first))]
          .push_back(&members);
    }
    if (members.size() >= kMinHypothesisSupport) all.push_back(&members);
  }
  for (const auto& [direction, members] : directions) {
    unions.push_back(members);
    if (true_repeated != nullptr) {
      unions.push_back(members);
      unions.back().push_back(true_repeated);
    }
  }
  if (all.size() > 3) unions.push_back(all);
  size_t best_f_count = best_e_count;
  std::vector<bool> best_f_mask;
  Eigen::Matrix3d best_f = Eigen::Matrix3d::Zero();
  std::vector<Eigen::Vector2d> y1, y2;
  for (const auto& members : unions) {
    y1.clear();
    y2.clear();
    for (const std::vector<size_t>* group : members) {
      for (size_t m : *group) {
        y1.push_back(x1[m]);
        y2.push_back(x2[m]);
      }
    }
    if (y1.size() < 8) continue;
    const Eigen::Matrix3d F = FitFundamental(y1, y2);
    const size_t count = CountInliers(F, x1, x2, max_sq_error, &mask);
    if (count > best_f_count) {
      best_f_count = count;
      best_f_mask = mask;
      best_f = F;
    }
    // The essential matrix closest to the fit: what the five-point RANSAC
    // finds near it.
    const EssentialHypothesis near = NearestEssential(scene.K, F);
    const size_t near_count =
        CountInliers(near.F, x1, x2, max_sq_error, &mask);
    if (near_count > best_e_count) {
      best_e_count = near_count;
      best_e_mask = mask;
      best_e = near;
    }
  }
  best_f_count = std::max(best_f_count, best_e_count);

  // Local optimisation, as LO-RANSAC: refit the best matrices to their
  // inliers while that gains inliers.
  auto refine = [&](bool essential, size_t* count, std::vector<bool>* best,
                    Eigen::Matrix3d* F, EssentialHypothesis* e) {
    for (int iteration = 0; iteration < kMaxLocalOptimisations; ++iteration) {
      y1.clear();
      y2.clear();
      for (size_t m = 0; m < num_matches; ++m) {
        if (!(*best)[m]) continue;
        y1.push_back(x1[m]);
        y2.push_back(x2[m]);
      }
      if (y1.size() < 8) return;
      const Eigen::Matrix3d fit = FitFundamental(y1, y2);
      const EssentialHypothesis near = NearestEssential(scene.K, fit);
      const Eigen::Matrix3d& candidate = essential ? near.F : fit;
      const size_t refined = CountInliers(candidate, x1, x2, max_sq_error, &mask);
      if (refined <= *count) return;
      *count = refined;
      *best = mask;
      if (essential) {
        *e = near;
      } else {
        *F = fit;
      }
    }
  };
  if (!best_e_mask.empty()) {
    refine(true, &best_e_count, &best_e_mask, nullptr, &best_e);
  }
  if (!best_f_mask.empty()) {
    refine(false, &best_f_count, &best_f_mask, &best_f, nullptr);
  }
  best_f_count = std::max(best_f_count, best_e_count);

  // Homographies fitted to each of the largest groups: a plane (a planar
  // facade, a rotation about the centre) explains one group.
  size_t best_h_count = 0;
  std::vector<bool> best_h_mask;
  Eigen::Matrix3d best_h = Eigen::Matrix3d::Zero();
  for (const std::vector<size_t>* group : largest) {
    if (group->size() < 8) continue;
    y1.clear();
    y2.clear();
    for (size_t m : *group) {
      y1.push_back(x1[m]);
      y2.push_back(x2[m]);
    }
    const Eigen::Matrix3d H = FitHomography(y1, y2);
    const size_t count =
        CountHomographyInliers(H, x1, x2, max_sq_error, &mask);
    if (count > best_h_count) {
      best_h_count = count;
      best_h_mask = mask;
      best_h = H;
    }
  }

  const bool calibrated =
      best_f_mask.empty() || best_e_count >= kMinEFInlierRatio * best_f_count;
  size_t best_count = calibrated ? best_e_count : best_f_count;
  const std::vector<bool>* best_mask = calibrated ? &best_e_mask : &best_f_mask;
  const bool planar =
      best_count > 0 && best_h_count > kMaxHInlierRatio * best_count;
  if (planar && best_h_count > best_count) {
    best_count = best_h_count;
    best_mask = &best_h_mask;
  }
  result.verified =
      best_count >= static_cast<size_t>(options.min_num_inliers) &&
      best_count >= options.min_inlier_ratio * num_matches;
  if (!result.verified) {
    result.hypothesis = 0;
    return result;
  }
  TwoViewGeometry& g = result.geometry;
  g.config = static_cast<int>(planar       ? TwoViewConfig::kPlanarOrPanoramic
                               : calibrated ? TwoViewConfig::kCalibrated
                                            : TwoViewConfig::kUncalibrated);
  g.E = best_e.E;
  g.F = calibrated ? Eigen::Matrix3d(best_e.F / best_e.F.norm()) : best_f;
  if (best_h.norm() > 0.0) g.H = best_h / best_h.norm();
  g.inlier_matches.reserve(best_count);
  for (size_t m = 0; m < num_matches; ++m) {
    if (!(*best_mask)[m]) continue;
    g.inlier_matches.push_back(matches.matches[m]);
    if (matches.labels[m] == 0) {
      ++result.num_true_inliers;
    } else if (matches.labels[m] == kOutlierMatchLabel) {
      ++result.num_random_inliers;
    } else {
      ++result.num_doppelganger_inliers;
    }
  }
  return result;
}

}  // namespace

size_t SynthPairMatches::NumTrueMatches() const {
  return std::count(labels.begin(), labels.end(), 0);
}

size_t SynthPairMatches::NumDoppelgangerMatches() const {
  return std::count_if(labels.begin(), labels.end(), [](int label) {
    return label != 0 && label != kOutlierMatchLabel;
  });
}

std::vector<ImagePair> FindSynthCandidatePairs(const SyntheticScene& scene) {
  if (scene.layout.family) return FindCovisiblePairs(scene);
  const SceneLayout& layout = scene.layout;
  const size_t n = layout.cams_from_world.size();
  const double r = layout.pair_radius;
  std::vector<Eigen::Vector3d> centers(n);
  for (size_t i = 0; i < n; ++i) {
    centers[i] = layout.cams_from_world[i].Inverse().translation;
  }
  auto cell_of = [r](const Eigen::Vector3d& x) {
    return Eigen::Vector3i(static_cast<int>(std::floor(x.x() / r)),
                           static_cast<int>(std::floor(x.y() / r)),
                           static_cast<int>(std::floor(x.z() / r)));
  };
  auto key_of = [](const Eigen::Vector3i& c) {
    return (static_cast<uint64_t>(static_cast<uint32_t>(c.x()) & 0x1fffff) << 42) |
           (static_cast<uint64_t>(static_cast<uint32_t>(c.y()) & 0x1fffff) << 21) |
           (static_cast<uint64_t>(static_cast<uint32_t>(c.z()) & 0x1fffff));
  };
  std::unordered_map<uint64_t, std::vector<uint32_t>> grid;
  for (uint32_t i = 0; i < n; ++i) grid[key_of(cell_of(centers[i]))].push_back(i);

  const std::vector<int> elements = layout.symmetry.Elements();
  std::vector<std::vector<uint64_t>> per_image(n);
  ParallelFor(n, scene.options.num_threads, [&](size_t j) {
    std::vector<uint64_t>& out = per_image[j];
    for (int k : elements) {
      const Eigen::Vector3d y = layout.symmetry.Transform(-k) * centers[j];
      const Eigen::Vector3i c = cell_of(y);
      for (int dx = -1; dx <= 1; ++dx) {
        for (int dy = -1; dy <= 1; ++dy) {
          for (int dz = -1; dz <= 1; ++dz) {
            auto it = grid.find(key_of(c + Eigen::Vector3i(dx, dy, dz)));
            if (it == grid.end()) continue;
            for (uint32_t i : it->second) {
              if (i == j || (centers[i] - y).norm() > r) continue;
              const uint64_t a = std::min<uint64_t>(i, j);
              const uint64_t b = std::max<uint64_t>(i, j);
              out.push_back((a << 32) | b);
            }
          }
        }
      }
    }
    std::sort(out.begin(), out.end());
    out.erase(std::unique(out.begin(), out.end()), out.end());
  }, 16);

  std::vector<uint64_t> all;
  for (std::vector<uint64_t>& v : per_image) {
    all.insert(all.end(), v.begin(), v.end());
    std::vector<uint64_t>().swap(v);
  }
  std::sort(all.begin(), all.end());
  all.erase(std::unique(all.begin(), all.end()), all.end());
  std::vector<ImagePair> pairs;
  pairs.reserve(all.size());
  for (uint64_t key : all) {
    pairs.emplace_back(static_cast<ImageId>((key >> 32) + 1),
                       static_cast<ImageId>((key & 0xffffffffULL) + 1));
  }
  return pairs;
}

SynthPairMatches MatchSynthImages(const SyntheticScene& scene, ImageId id1,
                                  ImageId id2) {
  SynthPairMatches result;
  result.pair = ImagePair(id1, id2);
  const SynthImage& image1 = scene.images.at(result.pair.image_id1 - 1);
  const SynthImage& image2 = scene.images.at(result.pair.image_id2 - 1);
  const SceneLayout& layout = scene.layout;
  const SynthOptions& options = scene.options;
  const float min_cosine =
      static_cast<float>(std::cos(options.max_view_angle * M_PI / 180.0));
  const float max_scale = static_cast<float>(options.max_scale_ratio);

  auto similarity = [&](uint32_t f1, uint32_t f2) -> float {
    const SynthFeature& a = image1.features[f1];
    const SynthFeature& b = image2.features[f2];
    const float c = a.local_view.dot(b.local_view);
    if (c < min_cosine) return -2.0f;
    const float s = a.distance > b.distance ? a.distance / b.distance
                                            : b.distance / a.distance;
    if (s > max_scale) return -2.0f;
    return c;
  };
  auto add_match = [&](uint32_t f1, uint32_t f2) {
    const uint32_t p1 = image1.features[f1].point_index;
    const uint32_t p2 = image2.features[f2].point_index;
    result.matches.push_back({f1, f2});
    result.labels.push_back(
        p1 == p2 ? 0
                 : layout.symmetry.Relation(layout.points[p1].replica,
                                            layout.points[p2].replica));
  };

  // Merge-join of the two sorted appearance lists.
  const auto& list1 = image1.appearance_index;
  const auto& list2 = image2.appearance_index;
  size_t a = 0, b = 0;
  std::vector<Candidate> best1, best2;
  while (a < list1.size() && b < list2.size()) {
    if (list1[a].first < list2[b].first) {
      ++a;
      continue;
    }
    if (list2[b].first < list1[a].first) {
      ++b;
      continue;
    }
    const uint32_t appearance = list1[a].first;
    size_t a_end = a, b_end = b;
    while (a_end < list1.size() && list1[a_end].first == appearance) ++a_end;
    while (b_end < list2.size() && list2[b_end].first == appearance) ++b_end;
    if (a_end - a == 1 && b_end - b == 1) {
      if (similarity(list1[a].second, list2[b].second) > -1.0f) {
        add_match(list1[a].second, list2[b].second);
      }
    } else {
      // Mutual best candidates by viewing-ray similarity.
      best1.assign(a_end - a, Candidate());
      best2.assign(b_end - b, Candidate());
      for (size_t x = a; x < a_end; ++x) {
        for (size_t y = b; y < b_end; ++y) {
          const float s = similarity(list1[x].second, list2[y].second);
          if (s < -1.0f) continue;
          if (s > best1[x - a].cosine) best1[x - a] = {s, static_cast<uint32_t>(y - b)};
          if (s > best2[y - b].cosine) best2[y - b] = {s, static_cast<uint32_t>(x - a)};
        }
      }
      for (size_t x = a; x < a_end; ++x) {
        const Candidate& c = best1[x - a];
        if (c.cosine < -1.0f || best2[c.index].index != x - a) continue;
        add_match(list1[x].second, list2[b + c.index].second);
      }
    }
    a = a_end;
    b = b_end;
  }

  // Random wrong matches between features not matched yet.
  if (!result.matches.empty() && options.outlier_ratio > 0.0) {
    SynthRandom rng(DeriveSeed(
        options.seed, 4,
        ImagePairToPairId(result.pair.image_id1, result.pair.image_id2)));
    const size_t num_outliers = static_cast<size_t>(std::floor(
        options.outlier_ratio * result.matches.size() + rng.Uniform()));
    std::vector<bool> used1(image1.features.size(), false);
    std::vector<bool> used2(image2.features.size(), false);
    for (const FeatureMatch& m : result.matches) {
      used1[m.idx1] = true;
      used2[m.idx2] = true;
    }
    for (size_t k = 0; k < num_outliers; ++k) {
      for (int attempt = 0; attempt < 20; ++attempt) {
        const uint32_t f1 = rng.UniformInt(static_cast<uint32_t>(used1.size()));
        const uint32_t f2 = rng.UniformInt(static_cast<uint32_t>(used2.size()));
        if (used1[f1] || used2[f2]) continue;
        used1[f1] = used2[f2] = true;
        result.matches.push_back({f1, f2});
        result.labels.push_back(kOutlierMatchLabel);
        break;
      }
    }
  }

  // Order by the first keypoint index.
  std::vector<size_t> order(result.matches.size());
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](size_t x, size_t y) {
    return result.matches[x].idx1 < result.matches[y].idx1;
  });
  std::vector<FeatureMatch> matches(order.size());
  std::vector<int> labels(order.size());
  for (size_t k = 0; k < order.size(); ++k) {
    matches[k] = result.matches[order[k]];
    labels[k] = result.labels[order[k]];
  }
  result.matches.swap(matches);
  result.labels.swap(labels);
  return result;
}

Rigid3d SynthHypothesisPose(const SyntheticScene& scene, ImageId id1,
                            ImageId id2, int k) {
  const Rigid3d& cam1_from_world = scene.images.at(id1 - 1).cam_from_world;
  const Rigid3d& cam2_from_world = scene.images.at(id2 - 1).cam_from_world;
  return cam2_from_world * scene.layout.symmetry.Transform(k) *
         cam1_from_world.Inverse();
}

SynthVerification VerifySynthMatches(const SyntheticScene& scene,
                                     const SynthPairMatches& matches) {
  if (scene.layout.family) return VerifyFamilyMatches(scene, matches);
  const SynthOptions& options = scene.options;
  SynthVerification result;
  result.geometry.pair = matches.pair;
  if (matches.matches.empty()) return result;

  // Hypotheses: the true geometry and every well-supported symmetry element.
  std::map<int, size_t> support;
  for (int label : matches.labels) {
    if (label != kOutlierMatchLabel && label != 0) ++support[label];
  }
  std::vector<int> hypotheses = {0};
  for (const auto& [label, count] : support) {
    if (count >= kMinHypothesisSupport) hypotheses.push_back(label);
  }

  const SynthImage& image1 = scene.images.at(matches.pair.image_id1 - 1);
  const SynthImage& image2 = scene.images.at(matches.pair.image_id2 - 1);
  const Eigen::Matrix3d K_inv = scene.K.inverse();
  const double max_sq_error = options.max_error * options.max_error;

  std::vector<bool> inliers, best_inliers;
  size_t best_count = 0;
  for (int k : hypotheses) {
    const Rigid3d pose = SynthHypothesisPose(scene, matches.pair.image_id1,
                                             matches.pair.image_id2, k);
    const double baseline = pose.translation.norm();
    if (baseline < 1e-9) continue;
    const Eigen::Vector3d t = pose.translation / baseline;
    const Eigen::Matrix3d E = CrossMatrix(t) * pose.rotation.toRotationMatrix();
    const Eigen::Matrix3d F = K_inv.transpose() * E * K_inv;
    inliers.assign(matches.matches.size(), false);
    size_t count = 0;
    for (size_t m = 0; m < matches.matches.size(); ++m) {
      const FeatureMatch& fm = matches.matches[m];
      const Eigen::Vector2d x1 = image1.features[fm.idx1].xy.cast<double>();
      const Eigen::Vector2d x2 = image2.features[fm.idx2].xy.cast<double>();
      if (SquaredSampsonError(F, x1, x2) <= max_sq_error) {
        inliers[m] = true;
        ++count;
      }
    }
    if (count > best_count) {
      best_count = count;
      best_inliers = inliers;
      result.hypothesis = k;
      result.geometry.E = E;
      result.geometry.F = F / F.norm();
      result.geometry.qvec = Eigen::Vector4d(pose.rotation.w(), pose.rotation.x(),
                                             pose.rotation.y(), pose.rotation.z());
      result.geometry.tvec = t;
    }
  }

  result.verified =
      best_count >= static_cast<size_t>(options.min_num_inliers) &&
      best_count >= options.min_inlier_ratio * matches.matches.size();
  if (!result.verified) {
    result.hypothesis = 0;
    return result;
  }
  result.geometry.config = static_cast<int>(TwoViewConfig::kCalibrated);
  result.geometry.inlier_matches.reserve(best_count);
  for (size_t m = 0; m < matches.matches.size(); ++m) {
    if (!best_inliers[m]) continue;
    result.geometry.inlier_matches.push_back(matches.matches[m]);
    if (matches.labels[m] == 0) {
      ++result.num_true_inliers;
    } else if (matches.labels[m] == kOutlierMatchLabel) {
      ++result.num_random_inliers;
    } else {
      ++result.num_doppelganger_inliers;
    }
  }
  return result;
}

void ForEachSynthPair(const SyntheticScene& scene, bool verify,
                      const std::function<void(const SynthPair&)>& fn) {
  const std::vector<ImagePair> candidates = FindSynthCandidatePairs(scene);
  const size_t num_batches = (candidates.size() + kBatchSize - 1) / kBatchSize;
  auto compute = [&](size_t batch) {
    const size_t begin = batch * kBatchSize;
    const size_t end = std::min(candidates.size(), begin + kBatchSize);
    std::vector<SynthPair> pairs(end - begin);
    ParallelFor(end - begin, scene.options.num_threads, [&](size_t k) {
      const ImagePair& pair = candidates[begin + k];
      SynthPair& out = pairs[k];
      out.matches = MatchSynthImages(scene, pair.image_id1, pair.image_id2);
      if (verify && !out.matches.matches.empty()) {
        out.verification = VerifySynthMatches(scene, out.matches);
      }
    }, 8);
    return pairs;
  };
  if (num_batches == 0) return;
  std::vector<SynthPair> current = compute(0);
  for (size_t batch = 0; batch < num_batches; ++batch) {
    std::future<std::vector<SynthPair>> next;
    if (batch + 1 < num_batches) {
      next = std::async(std::launch::async, compute, batch + 1);
    }
    for (const SynthPair& pair : current) {
      if (!pair.matches.matches.empty()) fn(pair);
    }
    if (next.valid()) current = next.get();
  }
}

}  // namespace hisfm
