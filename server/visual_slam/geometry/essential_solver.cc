#include "server/visual_slam/geometry/essential_solver.h"

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "absl/strings/str_cat.h"
#include "server/visual_slam/geometry/two_view.h"

namespace waymark::visual_slam {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

bool InRange(const std::vector<Correspondence>& c, const std::vector<int>& indices) {
  for (int i : indices)
    if (i < 0 || i >= static_cast<int>(c.size())) return false;
  return true;
}

// Hartley normalization: centroid to the origin, mean distance sqrt(2).
Eigen::Matrix3d Normalizer(const std::vector<Eigen::Vector2d>& points) {
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (const auto& p : points) mean += p;
  mean /= static_cast<double>(points.size());
  double spread = 0;
  for (const auto& p : points) spread += (p - mean).norm();
  spread /= static_cast<double>(points.size());
  const double s = spread > 1e-12 ? std::sqrt(2.0) / spread : 1.0;
  Eigen::Matrix3d T;
  T << s, 0, -s * mean.x(), 0, s, -s * mean.y(), 0, 0, 1;
  return T;
}

// Signed Sampson residuals of `indices` under `m`, with a Huber weight at `huber` (normalized).
double SampsonCost(const Motion& m, const std::vector<Correspondence>& c,
                   const std::vector<int>& indices, double huber, Eigen::VectorXd* residuals) {
  const Eigen::Matrix3d E = EssentialOf(m);
  residuals->resize(indices.size());
  double total = 0;
  for (size_t k = 0; k < indices.size(); ++k) {
    const Eigen::Vector3d xr(c[indices[k]].reference.x(), c[indices[k]].reference.y(), 1);
    const Eigen::Vector3d xc(c[indices[k]].current.x(), c[indices[k]].current.y(), 1);
    const Eigen::Vector3d ex = E * xr, etx = E.transpose() * xc;
    const double den = ex.head<2>().squaredNorm() + etx.head<2>().squaredNorm();
    const double r = den > 0 ? xc.dot(ex) / std::sqrt(den) : 0;
    (*residuals)(k) = r;
    const double a = std::abs(r);
    total += a <= huber ? 0.5 * r * r : huber * (a - 0.5 * huber);
  }
  return total;
}

// (R, t) moved by `delta`: rotation exp(delta[0..2]) applied on the left, the unit translation
// tilted along two directions orthogonal to it.
Motion Perturb(const Motion& m, const Eigen::Matrix<double, 5, 1>& delta) {
  const Eigen::Vector3d w = delta.head<3>();
  Motion out;
  const double angle = w.norm();
  const Eigen::Matrix3d dR = angle < 1e-15 ? Eigen::Matrix3d::Identity()
                                           : Eigen::AngleAxisd(angle, w / angle).toRotationMatrix();
  out.R = dR * m.R;
  Eigen::Vector3d b1 = m.t.unitOrthogonal();
  Eigen::Vector3d b2 = m.t.cross(b1).normalized();
  out.t = dR * (m.t + delta(3) * b1 + delta(4) * b2).normalized();
  return out;
}

// Levenberg-Marquardt on the Sampson errors of the inliers (Huber weight at about 1 px of a
// 500 px focal length): the linear 8-point solution minimizes an algebraic error that weighs the
// pairs unevenly, which costs degrees of translation direction on small baselines.
Motion RefineOnSampson(const Motion& start, const std::vector<Correspondence>& c,
                       const std::vector<int>& indices) {
  constexpr double kHuber = 1.0 / 500;
  constexpr double kStep = 1e-7;
  Motion m = start;
  Eigen::VectorXd r, r_step;
  double cost = SampsonCost(m, c, indices, kHuber, &r);
  double lambda = 1e-3;
  for (int iteration = 0; iteration < 10; ++iteration) {
    Eigen::MatrixXd J(indices.size(), 5);
    for (int p = 0; p < 5; ++p) {
      Eigen::Matrix<double, 5, 1> d = Eigen::Matrix<double, 5, 1>::Zero();
      d(p) = kStep;
      SampsonCost(Perturb(m, d), c, indices, kHuber, &r_step);
      J.col(p) = (r_step - r) / kStep;
    }
    Eigen::VectorXd w(indices.size());
    for (Eigen::Index k = 0; k < r.size(); ++k)
      w(k) = std::abs(r(k)) <= kHuber ? 1.0 : kHuber / std::abs(r(k));
    const Eigen::Matrix<double, 5, 5> H = J.transpose() * w.asDiagonal() * J;
    const Eigen::Matrix<double, 5, 1> g = J.transpose() * w.asDiagonal() * r;
    bool improved = false;
    for (int attempt = 0; attempt < 8 && !improved; ++attempt) {
      Eigen::Matrix<double, 5, 5> A = H;
      A.diagonal() *= 1 + lambda;
      A.diagonal().array() += 1e-12;
      const Eigen::Matrix<double, 5, 1> step = A.ldlt().solve(-g);
      if (!step.allFinite()) return m;
      const Motion next = Perturb(m, step);
      Eigen::VectorXd r_next;
      const double next_cost = SampsonCost(next, c, indices, kHuber, &r_next);
      if (next_cost < cost) {
        const bool converged = cost - next_cost < 1e-12 * cost;
        m = next, r = r_next, cost = next_cost;
        lambda = std::max(1e-9, lambda * 0.1);
        improved = true;
        if (converged) return m;
      } else {
        lambda *= 10;
      }
    }
    if (!improved) break;
  }
  return m;
}

}  // namespace

Motion PolishOnSampson(const Motion& start, const std::vector<Correspondence>& c,
                       const std::vector<int>& indices) {
  if (indices.size() < 5 || !InRange(c, indices)) return start;
  return RefineOnSampson(start, c, indices);
}

std::vector<Motion> FivePoint(const std::vector<Correspondence>& c,
                              const std::vector<int>& sample) {
  if (sample.size() != 5 || !InRange(c, sample)) return {};
  std::vector<cv::Point2d> ref, cur;
  for (int i : sample) {
    if (!c[i].reference.allFinite() || !c[i].current.allFinite()) return {};
    ref.emplace_back(c[i].reference.x(), c[i].reference.y());
    cur.emplace_back(c[i].current.x(), c[i].current.y());
  }
  // With exactly 5 points OpenCV's RANSAC runs the minimal solver once and returns all its
  // solutions stacked (3k x 3); normalized coordinates, so the camera matrix is the identity.
  cv::Mat stacked;
  try {
    stacked = cv::findEssentialMat(ref, cur, cv::Mat::eye(3, 3, CV_64F), cv::RANSAC, 0.999, 1.0);
  } catch (const cv::Exception&) {
    return {};
  }
  std::vector<Motion> out;
  if (stacked.empty() || stacked.cols != 3 || stacked.rows % 3 != 0) return out;
  stacked.convertTo(stacked, CV_64F);
  for (int k = 0; k < stacked.rows / 3; ++k) {
    Eigen::Matrix3d E;
    for (int r = 0; r < 3; ++r)
      for (int col = 0; col < 3; ++col) E(r, col) = stacked.at<double>(3 * k + r, col);
    if (!E.allFinite() || E.norm() < 1e-12) continue;
    const std::optional<Decomposition> d = DecomposeEssential(E, c, sample);
    if (d) out.push_back(d->motion);
  }
  return out;
}

std::optional<Eigen::Matrix3d> EssentialFromPairs(const std::vector<Correspondence>& c,
                                                  const std::vector<int>& indices) {
  if (indices.size() < 8 || !InRange(c, indices)) return std::nullopt;
  std::vector<Eigen::Vector2d> ref, cur;
  for (int i : indices) {
    if (!c[i].reference.allFinite() || !c[i].current.allFinite()) return std::nullopt;
    ref.push_back(c[i].reference);
    cur.push_back(c[i].current);
  }
  const Eigen::Matrix3d Tr = Normalizer(ref), Tc = Normalizer(cur);
  // Normal equations A^T A (9x9) of the rows a_k with a_k . f = x_c^T F x_r = sum_ij xc_i F_ij
  // xr_j (F row-major): their cost does not grow with the pairs beyond forming the sum, and
  // Hartley normalization keeps them well conditioned.
  Eigen::Matrix<double, 9, 9> AtA = Eigen::Matrix<double, 9, 9>::Zero();
  for (size_t k = 0; k < indices.size(); ++k) {
    const Eigen::Vector3d xr = Tr * Eigen::Vector3d(ref[k].x(), ref[k].y(), 1);
    const Eigen::Vector3d xc = Tc * Eigen::Vector3d(cur[k].x(), cur[k].y(), 1);
    Eigen::Matrix<double, 9, 1> a;
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) a(3 * i + j) = xc(i) * xr(j);
    AtA.selfadjointView<Eigen::Lower>().rankUpdate(a);
  }
  AtA = AtA.selfadjointView<Eigen::Lower>();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 9, 9>> eig(AtA);
  if (eig.info() != Eigen::Success) return std::nullopt;
  const Eigen::Matrix<double, 9, 1>& lambda = eig.eigenvalues();  // ascending
  // lambda(1) is the smallest eigenvalue besides the solution's: near zero (relative to the
  // largest; 1e-14 is sigma ratio 1e-7, well above rounding) means a null space of two or more
  // dimensions: degenerate structure, pure rotation, repeated pairs.
  if (!(lambda(1) > 1e-14 * lambda(8))) return std::nullopt;
  const Eigen::Matrix<double, 9, 1> f = eig.eigenvectors().col(0);
  Eigen::Matrix3d F;
  F << f(0), f(1), f(2), f(3), f(4), f(5), f(6), f(7), f(8);
  Eigen::Matrix3d E = Tc.transpose() * F * Tr;
  Eigen::JacobiSVD<Eigen::Matrix3d> esvd(E, Eigen::ComputeFullU | Eigen::ComputeFullV);
  E = esvd.matrixU() * Eigen::Vector3d(1, 1, 0).asDiagonal() * esvd.matrixV().transpose();
  if (!E.allFinite()) return std::nullopt;
  return E;
}

std::optional<Decomposition> DecomposeEssential(const Eigen::Matrix3d& E,
                                                const std::vector<Correspondence>& c,
                                                const std::vector<int>& indices) {
  if (!E.allFinite() || !InRange(c, indices)) return std::nullopt;
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(E, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d U = svd.matrixU(), V = svd.matrixV();
  if (U.determinant() < 0) U = -U;
  if (V.determinant() < 0) V = -V;
  Eigen::Matrix3d W;
  W << 0, -1, 0, 1, 0, 0, 0, 0, 1;
  const Eigen::Matrix3d rotations[2] = {U * W * V.transpose(), U * W.transpose() * V.transpose()};
  const Eigen::Vector3d t = U.col(2).normalized();
  std::optional<Decomposition> best;
  for (const Eigen::Matrix3d& R : rotations) {
    for (double sign : {1.0, -1.0}) {
      Decomposition d;
      d.motion.R = R;
      d.motion.t = sign * t;
      for (int i : indices) {
        const auto depths = PairDepths(d.motion, c[i].reference, c[i].current);
        if (depths && (*depths)(0) > 0 && (*depths)(1) > 0) ++d.in_front;
      }
      if (d.in_front > 0 && (!best || d.in_front > best->in_front)) best = d;
    }
  }
  return best;
}

EssentialSolver::EssentialSolver(const std::vector<Correspondence>& correspondences,
                                 double focal_px)
    : correspondences_(correspondences), focal_px_(focal_px) {}

std::vector<Motion> EssentialSolver::Solve(const std::vector<int>& sample) const {
  if (sample.size() == 5) {
    // A sample that one rotation explains (pure rotation, or only far points) carries no
    // translation: every t fits it, yet the five-point solver would still return motions. The
    // 8-point path rejects such samples by its null space; here the best rotation between the
    // bearings (Kabsch) must leave at least one pair kMinParallaxPx away.
    constexpr double kMinParallaxPx = 0.5;
    if (!InRange(correspondences_, sample)) return {};
    std::vector<Eigen::Vector3d> br, bc;
    Eigen::Matrix3d H = Eigen::Matrix3d::Zero();
    for (int i : sample) {
      const Correspondence& c = correspondences_[i];
      br.push_back(Eigen::Vector3d(c.reference.x(), c.reference.y(), 1).normalized());
      bc.push_back(Eigen::Vector3d(c.current.x(), c.current.y(), 1).normalized());
      H += bc.back() * br.back().transpose();
    }
    if (!H.allFinite()) return {};
    Eigen::JacobiSVD<Eigen::Matrix3d> svd(H, Eigen::ComputeFullU | Eigen::ComputeFullV);
    const double det = (svd.matrixU() * svd.matrixV().transpose()).determinant();
    const Eigen::Matrix3d R = svd.matrixU() * Eigen::Vector3d(1, 1, det > 0 ? 1 : -1).asDiagonal() *
                              svd.matrixV().transpose();
    double most = 0;
    for (size_t k = 0; k < br.size(); ++k) most = std::max(most, (R * br[k] - bc[k]).norm());
    if (!(most * focal_px_ >= kMinParallaxPx)) return {};
    return FivePoint(correspondences_, sample);
  }
  const std::optional<Eigen::Matrix3d> E = EssentialFromPairs(correspondences_, sample);
  if (!E) return {};
  const std::optional<Decomposition> d = DecomposeEssential(*E, correspondences_, sample);
  if (!d) return {};
  return {d->motion};
}

double EssentialSolver::ErrorPx(const Motion& motion, int i) const {
  if (i < 0 || i >= static_cast<int>(correspondences_.size())) return kInf;
  const Correspondence& c = correspondences_[i];
  return SampsonDistance(EssentialOf(motion), c.reference, c.current) * focal_px_;
}

std::optional<Motion> EssentialSolver::Refine(const Motion& motion,
                                              const std::vector<int>& inliers) const {
  absl::StatusOr<Motion> m = EssentialFromInliers(correspondences_, inliers);
  if (!m.ok()) return std::nullopt;
  return *m;
}

void EssentialSolver::ErrorsPx(const Motion& motion, const std::vector<int>& indices,
                               std::vector<double>* errors) const {
  const Eigen::Matrix3d E = EssentialOf(motion);
  errors->resize(indices.size());
  for (size_t k = 0; k < indices.size(); ++k) {
    const int i = indices[k];
    (*errors)[k] =
        i < 0 || i >= static_cast<int>(correspondences_.size())
            ? kInf
            : SampsonDistance(E, correspondences_[i].reference, correspondences_[i].current) *
                  focal_px_;
  }
}

absl::StatusOr<Motion> EssentialFromInliers(const std::vector<Correspondence>& c,
                                            const std::vector<int>& inliers) {
  if (inliers.size() < 8) {
    return absl::InvalidArgumentError(
        absl::StrCat("the essential matrix needs at least 8 inliers, got ", inliers.size()));
  }
  if (!InRange(c, inliers)) {
    return absl::InvalidArgumentError("an inlier index is outside the correspondences");
  }
  const std::optional<Eigen::Matrix3d> E = EssentialFromPairs(c, inliers);
  if (!E) {
    return absl::FailedPreconditionError(
        "the inliers do not determine an essential matrix (degenerate structure or no "
        "translation)");
  }
  const std::optional<Decomposition> d = DecomposeEssential(*E, c, inliers);
  if (!d || 2 * d->in_front < static_cast<int>(inliers.size())) {
    return absl::FailedPreconditionError(
        absl::StrCat("no decomposition of E puts half of the ", inliers.size(),
                     " inliers in front of both cameras (", d ? d->in_front : 0, ")"));
  }
  // Pairs behind a camera under the voted motion contradict it: outliers that happen to lie near
  // an epipolar line, or points too far for their parallax to show. Neither helps to pin the
  // translation down, so the motion is estimated again without them and then polished.
  std::vector<int> in_front;
  for (int i : inliers) {
    const auto depths = PairDepths(d->motion, c[i].reference, c[i].current);
    if (depths && (*depths)(0) > 0 && (*depths)(1) > 0) in_front.push_back(i);
  }
  Motion linear = d->motion;
  if (in_front.size() >= 8 && in_front.size() < inliers.size()) {
    const std::optional<Eigen::Matrix3d> E2 = EssentialFromPairs(c, in_front);
    const std::optional<Decomposition> d2 =
        E2 ? DecomposeEssential(*E2, c, in_front) : std::nullopt;
    if (d2 && 2 * d2->in_front >= static_cast<int>(in_front.size())) linear = d2->motion;
  }
  const Motion refined = RefineOnSampson(linear, c, in_front.size() >= 8 ? in_front : inliers);
  // Keep the polish only while it stays the decomposition the cheirality vote picks.
  const std::optional<Decomposition> check = DecomposeEssential(EssentialOf(refined), c, inliers);
  if (!refined.R.allFinite() || !refined.t.allFinite() || !check ||
      (check->motion.t - refined.t).norm() > 1e-6 || (check->motion.R - refined.R).norm() > 1e-6) {
    return linear;
  }
  return refined;
}

}  // namespace waymark::visual_slam
