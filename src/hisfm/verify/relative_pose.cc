#include "hisfm/verify/relative_pose.h"

#include <ceres/ceres.h>

#include <Eigen/Dense>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <random>

#include "hisfm/util/error.h"
#include "hisfm/verify/triangulation.h"

namespace hisfm {
namespace {

Eigen::Matrix3d Skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d S;
  S << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return S;
}

// Squared Sampson distance (normalized units) of a correspondence.
double SquaredSampson(const Eigen::Matrix3d& E, const Eigen::Vector2d& x1,
                      const Eigen::Vector2d& x2) {
  const Eigen::Vector3d h1 = x1.homogeneous();
  const Eigen::Vector3d h2 = x2.homogeneous();
  const Eigen::Vector3d Ex1 = E * h1;
  const Eigen::Vector3d Etx2 = E.transpose() * h2;
  const double num = h2.dot(Ex1);
  const double den = Ex1.head<2>().squaredNorm() + Etx2.head<2>().squaredNorm();
  if (den <= 0) return std::numeric_limits<double>::infinity();
  return num * num / den;
}

// The two rotations of E's decomposition (Hartley & Zisserman, Result 9.19).
std::vector<Eigen::Matrix3d> RotationsOfEssential(const Eigen::Matrix3d& E) {
  const Eigen::JacobiSVD<Eigen::Matrix3d> svd(
      E, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d U = svd.matrixU();
  Eigen::Matrix3d V = svd.matrixV();
  if (U.determinant() < 0) U *= -1;
  if (V.determinant() < 0) V *= -1;
  Eigen::Matrix3d W;
  W << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  return {U * W * V.transpose(), U * W.transpose() * V.transpose()};
}

// The essential matrix through eight (or more) correspondences: the least-
// squares null vector of the epipolar constraints, projected onto the
// essential manifold (two equal singular values, one zero).
Eigen::Matrix3d EightPoint(const std::vector<Eigen::Vector2d>& x1,
                           const std::vector<Eigen::Vector2d>& x2,
                           const int* sample, int n) {
  Eigen::Matrix<double, Eigen::Dynamic, 9> A(n, 9);
  for (int r = 0; r < n; ++r) {
    const Eigen::Vector3d a = x1[sample[r]].homogeneous();
    const Eigen::Vector3d b = x2[sample[r]].homogeneous();
    for (int u = 0; u < 3; ++u) {
      for (int v = 0; v < 3; ++v) A(r, 3 * u + v) = b(u) * a(v);
    }
  }
  const Eigen::JacobiSVD<Eigen::Matrix<double, Eigen::Dynamic, 9>> svd(
      A, Eigen::ComputeFullV);
  const Eigen::Matrix<double, 9, 1> e = svd.matrixV().col(8);
  Eigen::Matrix3d E;
  E << e(0), e(1), e(2), e(3), e(4), e(5), e(6), e(7), e(8);
  const Eigen::JacobiSVD<Eigen::Matrix3d> s(
      E, Eigen::ComputeFullU | Eigen::ComputeFullV);
  return s.matrixU() * Eigen::Vector3d(1, 1, 0).asDiagonal() *
         s.matrixV().transpose();
}

// Signed Sampson distance of one correspondence, for Ceres.
struct SampsonResidual {
  SampsonResidual(const Eigen::Vector2d& x1, const Eigen::Vector2d& x2,
                  double focal)
      : x1_(x1), x2_(x2), focal_(focal) {}

  template <typename T>
  bool operator()(const T* q, const T* t, T* residual) const {
    // q is Eigen's (x, y, z, w) order, as EigenQuaternionManifold expects.
    const Eigen::Quaternion<T> rotation(q[3], q[0], q[1], q[2]);
    const Eigen::Matrix<T, 3, 3> R = rotation.toRotationMatrix();
    Eigen::Matrix<T, 3, 3> tx;
    tx << T(0), -t[2], t[1], t[2], T(0), -t[0], -t[1], t[0], T(0);
    const Eigen::Matrix<T, 3, 3> E = tx * R;
    const Eigen::Matrix<T, 3, 1> h1(T(x1_.x()), T(x1_.y()), T(1));
    const Eigen::Matrix<T, 3, 1> h2(T(x2_.x()), T(x2_.y()), T(1));
    const Eigen::Matrix<T, 3, 1> Ex1 = E * h1;
    const Eigen::Matrix<T, 3, 1> Etx2 = E.transpose() * h2;
    const T den = Ex1(0) * Ex1(0) + Ex1(1) * Ex1(1) + Etx2(0) * Etx2(0) +
                  Etx2(1) * Etx2(1);
    residual[0] = T(focal_) * h2.dot(Ex1) / sqrt(den + T(1e-30));
    return true;
  }

  Eigen::Vector2d x1_, x2_;
  double focal_;
};

struct Hypothesis {
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  int support = -1;
};

int CountSupport(const Eigen::Matrix3d& R, const Eigen::Vector3d& t,
                 const std::vector<Eigen::Vector2d>& x1,
                 const std::vector<Eigen::Vector2d>& x2, double max_error,
                 double min_angle_cos, std::vector<int>* support = nullptr) {
  const Eigen::Matrix3d E = Skew(t) * R;
  int count = 0;
  if (support) support->clear();
  for (size_t k = 0; k < x1.size(); ++k) {
    if (SupportsPose(R, t, E, x1[k], x2[k], max_error, min_angle_cos)) {
      ++count;
      if (support) support->push_back(static_cast<int>(k));
    }
  }
  return count;
}

// True if the rays of (x1, x2) meet at an angle whose cosine exceeds
// min_angle_cos (too close to parallel to vote on cheirality).
bool RaysNearlyParallel(const Eigen::Matrix3d& R, const Eigen::Vector2d& x1,
                        const Eigen::Vector2d& x2, double min_angle_cos) {
  const Eigen::Vector3d a = R * x1.homogeneous();
  const Eigen::Vector3d b = x2.homogeneous();
  return a.dot(b) > min_angle_cos * a.norm() * b.norm();
}

// Scores the hypotheses (R, t0) and (R, -t0), in that order, into the best
// hypothesis of each translation sign (measured against reference_t).
void ScoreBothSigns(const Eigen::Matrix3d& R, const Eigen::Vector3d& t0,
                    const Eigen::Vector3d& reference_t,
                    const std::vector<Eigen::Vector2d>& x1,
                    const std::vector<Eigen::Vector2d>& x2, double max_error,
                    double min_angle_cos, Hypothesis best[2]) {
  const int s_plus = t0.dot(reference_t) >= 0 ? 0 : 1;
  const int s_minus = (-t0).dot(reference_t) >= 0 ? 0 : 1;
  int plus = 0, minus = 0;
  CountSupportBothSigns(R, t0, x1, x2, max_error, min_angle_cos,
                        best[s_plus].support, best[s_minus].support, &plus,
                        &minus);
  if (plus > best[s_plus].support) best[s_plus] = {R, t0, plus};
  if (minus > best[s_minus].support) best[s_minus] = {R, -t0, minus};
}

// Refines (R, t) on its support by least squares of the Sampson distance.
void Refine(const std::vector<Eigen::Vector2d>& x1,
            const std::vector<Eigen::Vector2d>& x2, double focal,
            const RelativePoseOptions& options, Hypothesis* h) {
  const double error = options.max_error_px / focal;
  const double angle_cos =
      std::cos(options.min_cheirality_angle_deg * M_PI / 180.0);
  std::vector<int> support;
  for (int round = 0; round < options.num_refinements; ++round) {
    CountSupport(h->R, h->t, x1, x2, error, angle_cos, &support);
    if (support.size() < 5) break;
    Eigen::Quaterniond q(h->R);
    double qv[4] = {q.x(), q.y(), q.z(), q.w()};
    double tv[3] = {h->t.x(), h->t.y(), h->t.z()};
    ceres::Problem problem;
    for (const int k : support) {
      problem.AddResidualBlock(
          new ceres::AutoDiffCostFunction<SampsonResidual, 1, 4, 3>(
              new SampsonResidual(x1[k], x2[k], focal)),
          new ceres::HuberLoss(options.max_error_px), qv, tv);
    }
    problem.SetManifold(qv, new ceres::EigenQuaternionManifold());
    problem.SetManifold(tv, new ceres::SphereManifold<3>());
    ceres::Solver::Options solver;
    solver.linear_solver_type = ceres::DENSE_QR;
    solver.max_num_iterations = 10;
    solver.num_threads = 1;
    solver.logging_type = ceres::SILENT;
    ceres::Solver::Summary summary;
    ceres::Solve(solver, &problem, &summary);
    const Eigen::Quaterniond qr(qv[3], qv[0], qv[1], qv[2]);
    const Eigen::Vector3d tr(tv[0], tv[1], tv[2]);
    if (!qr.coeffs().allFinite() || !tr.allFinite() || tr.norm() < 1e-12) {
      break;
    }
    h->R = qr.normalized().toRotationMatrix();
    h->t = tr.normalized();
  }
  h->support = CountSupport(h->R, h->t, x1, x2,
                            options.support_error_px / focal, angle_cos);
}

}  // namespace

void RelativePoseOptions::Check() const {
  HISFM_CHECK_OPTION(max_error_px, max_error_px > 0, "> 0");
  HISFM_CHECK_OPTION(support_error_px, support_error_px > 0, "> 0");
  HISFM_CHECK_OPTION(num_samples, num_samples >= 1, ">= 1");
  HISFM_CHECK_OPTION(num_eight_point_samples,
                     num_eight_point_samples >= 0, ">= 0");
  HISFM_CHECK_OPTION(num_refinements, num_refinements >= 0, ">= 0");
  HISFM_CHECK_OPTION(min_cheirality_angle_deg,
                     min_cheirality_angle_deg >= 0 &&
                     min_cheirality_angle_deg < 90,
                     "in [0, 90)");
}

bool SupportsPose(const Eigen::Matrix3d& R, const Eigen::Vector3d& t,
                  const Eigen::Matrix3d& E, const Eigen::Vector2d& x1,
                  const Eigen::Vector2d& x2, double max_error,
                  double min_angle_cos) {
  if (!(SquaredSampson(E, x1, x2) < max_error * max_error)) return false;
  double d1 = 0, d2 = 0;
  if (RayDepths(R, t, x1, x2, &d1, &d2) && d1 > 0 && d2 > 0) return true;
  // Not in front: neutral only if the rays are too close to parallel.
  return RaysNearlyParallel(R, x1, x2, min_angle_cos);
}

void CountSupportBothSigns(const Eigen::Matrix3d& R, const Eigen::Vector3d& t,
                           const std::vector<Eigen::Vector2d>& x1,
                           const std::vector<Eigen::Vector2d>& x2,
                           double max_error, double min_angle_cos,
                           int at_most_plus, int at_most_minus, int* plus,
                           int* minus) {
  const Eigen::Matrix3d E = Skew(t) * R;
  const int n = static_cast<int>(x1.size());
  int count_plus = 0;
  int count_minus = 0;
  for (int k = 0; k < n; ++k) {
    const int remaining = n - k;
    if (count_plus + remaining <= at_most_plus &&
        count_minus + remaining <= at_most_minus) {
      break;
    }
    if (!(SquaredSampson(E, x1[k], x2[k]) < max_error * max_error)) continue;
    double d1 = 0, d2 = 0;
    const bool depths = RayDepths(R, t, x1[k], x2[k], &d1, &d2);
    const bool front_plus = depths && d1 > 0 && d2 > 0;
    const bool front_minus = depths && d1 < 0 && d2 < 0;
    const bool parallel = (!front_plus || !front_minus) &&
                          RaysNearlyParallel(R, x1[k], x2[k], min_angle_cos);
    count_plus += front_plus || parallel;
    count_minus += front_minus || parallel;
  }
  *plus = count_plus;
  *minus = count_minus;
}

Eigen::Matrix3d EssentialOfPose(const Rigid3d& cam2_from_cam1) {
  return Skew(cam2_from_cam1.translation) *
         cam2_from_cam1.rotation.toRotationMatrix();
}

std::vector<RelativePoseHypothesis> EstimateRelativePose(
    const Eigen::Matrix3d& E_prior, const std::vector<Eigen::Vector2d>& x1,
    const std::vector<Eigen::Vector2d>& x2, double focal,
    const RelativePoseOptions& options) {
  std::vector<RelativePoseHypothesis> out;
  const int n = static_cast<int>(x1.size());
  if (n < 5 || x2.size() != x1.size() || !E_prior.allFinite() ||
      E_prior.norm() < 1e-12 || !(focal > 0)) {
    return out;
  }
  const double error = options.max_error_px / focal;
  const double angle_cos =
      std::cos(options.min_cheirality_angle_deg * M_PI / 180.0);
  std::mt19937 rng(options.seed);
  std::uniform_int_distribution<int> pick(0, n - 1);
  // best[s]: the best hypothesis with translation sign s, the sign measured
  // against the first rotation candidate's translation of E_prior.
  Hypothesis best[2];
  Eigen::Vector3d reference_t = Eigen::Vector3d::Zero();
  for (const Eigen::Matrix3d& R : RotationsOfEssential(E_prior)) {
    std::vector<Eigen::Vector3d> c(n);
    for (int k = 0; k < n; ++k) {
      c[k] = (R * x1[k].homogeneous()).cross(x2[k].homogeneous());
    }
    // The prior's own translation (null vector of E^T) is one hypothesis.
    const Eigen::JacobiSVD<Eigen::Matrix3d> svd(E_prior, Eigen::ComputeFullU);
    std::vector<Eigen::Vector3d> candidates = {svd.matrixU().col(2)};
    for (int s = 0; s < options.num_samples; ++s) {
      const int a = pick(rng);
      const int b = pick(rng);
      if (a == b) continue;
      const Eigen::Vector3d t = c[a].cross(c[b]);
      if (t.norm() > 1e-12) candidates.push_back(t.normalized());
    }
    if (reference_t.isZero()) reference_t = candidates.front();
    for (const Eigen::Vector3d& t0 : candidates) {
      ScoreBothSigns(R, t0, reference_t, x1, x2, error, angle_cos, best);
    }
  }
  // Full poses from eight-point samples compete under the same count.
  if (n >= 8) {
    int sample[8];
    for (int s = 0; s < options.num_eight_point_samples; ++s) {
      for (int k = 0; k < 8; ++k) sample[k] = pick(rng);
      const Eigen::Matrix3d E = EightPoint(x1, x2, sample, 8);
      if (!E.allFinite()) continue;
      const Eigen::JacobiSVD<Eigen::Matrix3d> svd(E, Eigen::ComputeFullU);
      const Eigen::Vector3d t0 = svd.matrixU().col(2);
      for (const Eigen::Matrix3d& R : RotationsOfEssential(E)) {
        ScoreBothSigns(R, t0, reference_t, x1, x2, error, angle_cos, best);
      }
    }
  }
  for (Hypothesis& h : best) {
    if (h.support < 0) continue;
    Refine(x1, x2, focal, options, &h);
    out.push_back({Rigid3d(Eigen::Quaterniond(h.R).normalized(), h.t),
                   h.support});
  }
  std::stable_sort(out.begin(), out.end(),
                   [](const RelativePoseHypothesis& a,
                      const RelativePoseHypothesis& b) {
                     return a.num_support > b.num_support;
                   });
  return out;
}

}  // namespace hisfm
