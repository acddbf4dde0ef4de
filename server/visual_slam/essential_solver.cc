#include "server/visual_slam/essential_solver.h"

#include <cmath>
#include <limits>

#include <Eigen/SVD>

#include "absl/strings/str_cat.h"
#include "server/visual_slam/two_view.h"

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

}  // namespace

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
  Eigen::MatrixXd A(indices.size(), 9);
  for (size_t k = 0; k < indices.size(); ++k) {
    const Eigen::Vector3d xr = Tr * Eigen::Vector3d(ref[k].x(), ref[k].y(), 1);
    const Eigen::Vector3d xc = Tc * Eigen::Vector3d(cur[k].x(), cur[k].y(), 1);
    // x_c^T F x_r = sum_ij xc_i F_ij xr_j, F row-major.
    for (int i = 0; i < 3; ++i)
      for (int j = 0; j < 3; ++j) A(k, 3 * i + j) = xc(i) * xr(j);
  }
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(A, Eigen::ComputeFullV);
  const Eigen::VectorXd& sigma = svd.singularValues();
  // sigma(7) is the smallest singular value besides the solution's: near zero means a null space of
  // two or more dimensions (degenerate structure, pure rotation, repeated pairs).
  if (sigma.size() < 8 || !(sigma(7) > 1e-9 * sigma(0))) return std::nullopt;
  const Eigen::VectorXd f = svd.matrixV().col(8);
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
    return absl::FailedPreconditionError(absl::StrCat(
        "no decomposition of E puts half of the ", inliers.size(),
        " inliers in front of both cameras (", d ? d->in_front : 0, ")"));
  }
  return d->motion;
}

}  // namespace waymark::visual_slam
