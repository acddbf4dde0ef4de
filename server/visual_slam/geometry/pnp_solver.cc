#include "server/visual_slam/geometry/pnp_solver.h"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <cmath>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include "absl/strings/str_cat.h"

namespace waymark::visual_slam {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kMinDepth = 1e-6;  // m; closer to the camera plane is "behind"

bool HasPoint(const Correspondence& c) {
  return c.reference_point && c.reference_point->allFinite() && c.reference_point->z() > kMinDepth;
}

Eigen::Matrix3d ExpSo3(const Eigen::Vector3d& w) {
  const double angle = w.norm();
  if (angle < 1e-12) return Eigen::Matrix3d::Identity();
  return Eigen::AngleAxisd(angle, w / angle).toRotationMatrix();
}

}  // namespace

PnpSolver::PnpSolver(const std::vector<Correspondence>& correspondences, double focal_px)
    : correspondences_(correspondences), focal_px_(focal_px) {}

bool PnpSolver::Samplable(int i) const {
  return i >= 0 && i < static_cast<int>(correspondences_.size()) && HasPoint(correspondences_[i]) &&
         correspondences_[i].current.allFinite();
}

std::vector<Motion> PnpSolver::Solve(const std::vector<int>& sample) const {
  if (sample.size() != 3) return {};
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2d> image;
  for (int i : sample) {
    if (!Samplable(i)) return {};
    const Correspondence& c = correspondences_[i];
    object.emplace_back(c.reference_point->x(), c.reference_point->y(), c.reference_point->z());
    image.emplace_back(c.current.x(), c.current.y());
  }
  std::vector<cv::Mat> rvecs, tvecs;
  try {
    // Normalized coordinates: the identity is the camera matrix.
    cv::solveP3P(object, image, cv::Mat::eye(3, 3, CV_64F), cv::Mat(), rvecs, tvecs,
                 cv::SOLVEPNP_P3P);
  } catch (const cv::Exception&) {
    return {};  // degenerate sample (collinear points, ...): no hypothesis
  }
  std::vector<Motion> motions;
  for (size_t k = 0; k < rvecs.size() && k < tvecs.size(); ++k) {
    cv::Mat R_cv;
    cv::Rodrigues(rvecs[k], R_cv);
    Motion m;
    cv::cv2eigen(R_cv, m.R);
    cv::Mat t_cv;
    tvecs[k].convertTo(t_cv, CV_64F);
    m.t = Eigen::Vector3d(t_cv.at<double>(0), t_cv.at<double>(1), t_cv.at<double>(2));
    if (!m.R.allFinite() || !m.t.allFinite()) continue;
    bool in_front = true;
    for (int i : sample) in_front &= (m.R * *correspondences_[i].reference_point + m.t).z() > 0;
    if (in_front) motions.push_back(m);
  }
  return motions;
}

double PnpSolver::ErrorPx(const Motion& motion, int i) const {
  if (i < 0 || i >= static_cast<int>(correspondences_.size())) return kInf;
  const Correspondence& c = correspondences_[i];
  if (!HasPoint(c)) return kInf;
  const Eigen::Vector3d X = motion.R * *c.reference_point + motion.t;
  if (!(X.z() > kMinDepth)) return kInf;
  const double e = (X.head<2>() / X.z() - c.current).norm() * focal_px_;
  return std::isfinite(e) ? e : kInf;
}

std::optional<Motion> PnpSolver::Refine(const Motion& motion,
                                        const std::vector<int>& inliers) const {
  absl::StatusOr<Motion> m = RefinePnp(correspondences_, inliers, motion, focal_px_);
  if (!m.ok()) return std::nullopt;
  return *m;
}

absl::StatusOr<Motion> RefinePnp(const std::vector<Correspondence>& c,
                                 const std::vector<int>& inliers, const Motion& initial,
                                 double focal_px) {
  if (!(focal_px > 0) || !std::isfinite(focal_px)) {
    return absl::InvalidArgumentError(
        absl::StrCat("focal length must be positive, got ", focal_px));
  }
  std::vector<int> used;
  for (int i : inliers) {
    if (i < 0 || i >= static_cast<int>(c.size())) {
      return absl::InvalidArgumentError("an inlier index is outside the correspondences");
    }
    if (HasPoint(c[i]) && c[i].current.allFinite()) used.push_back(i);
  }
  if (!initial.R.allFinite() || !initial.t.allFinite()) {
    return absl::InvalidArgumentError("the initial motion is not finite");
  }
  const double huber = 1.0 / focal_px;  // 1 px in normalized units

  // Robust cost of `m`; counts the points in front of the camera.
  auto cost = [&](const Motion& m, int* in_front) {
    double total = 0;
    *in_front = 0;
    for (int i : used) {
      const Eigen::Vector3d X = m.R * *c[i].reference_point + m.t;
      if (!(X.z() > kMinDepth)) continue;
      ++*in_front;
      const double r = (X.head<2>() / X.z() - c[i].current).norm();
      total += r <= huber ? 0.5 * r * r : huber * (r - 0.5 * huber);
    }
    return total;
  };

  Motion m = initial;
  int in_front = 0;
  double current_cost = cost(m, &in_front);
  if (in_front < 4) {
    return absl::InvalidArgumentError(absl::StrCat(
        "PnP refinement needs at least 4 inliers with depth in front of the camera, got ",
        in_front));
  }
  double lambda = 1e-4;
  bool converged = false;
  for (int iteration = 0; iteration < 30 && !converged; ++iteration) {
    // Perturbation X_c' = exp(w) X_c + d: Jacobian of X_c is [-X_c^, I].
    Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 1> g = Eigen::Matrix<double, 6, 1>::Zero();
    for (int i : used) {
      const Eigen::Vector3d X = m.R * *c[i].reference_point + m.t;
      if (!(X.z() > kMinDepth)) continue;
      const double iz = 1.0 / X.z();
      const Eigen::Vector2d r = X.head<2>() * iz - c[i].current;
      const double rn = r.norm();
      const double w = rn <= huber ? 1.0 : huber / rn;  // IRLS weight of the Huber loss
      Eigen::Matrix<double, 2, 3> P;
      P << iz, 0, -X.x() * iz * iz, 0, iz, -X.y() * iz * iz;
      Eigen::Matrix<double, 3, 6> dX;
      dX << 0, X.z(), -X.y(), 1, 0, 0,  //
          -X.z(), 0, X.x(), 0, 1, 0,    //
          X.y(), -X.x(), 0, 0, 0, 1;
      const Eigen::Matrix<double, 2, 6> J = P * dX;
      H += w * J.transpose() * J;
      g += w * J.transpose() * r;
    }
    bool improved = false;
    for (int attempt = 0; attempt < 10 && !improved; ++attempt) {
      Eigen::Matrix<double, 6, 6> A = H;
      A.diagonal() *= 1 + lambda;
      const Eigen::Matrix<double, 6, 1> step = A.ldlt().solve(-g);
      if (!step.allFinite()) break;
      Motion next;
      const Eigen::Matrix3d dR = ExpSo3(step.head<3>());
      next.R = dR * m.R;
      next.t = dR * m.t + step.tail<3>();
      int next_front = 0;
      const double next_cost = cost(next, &next_front);
      if (next_front >= 4 && next_cost < current_cost) {
        const double decrease = current_cost - next_cost;
        m = next;
        current_cost = next_cost;
        lambda = std::max(1e-9, lambda * 0.1);
        improved = true;
        converged = decrease < 1e-14 * (1 + current_cost) || step.norm() < 1e-12;
      } else {
        lambda *= 10;
      }
    }
    if (!improved) break;
  }
  // Re-orthonormalize against drift from the multiplied updates.
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(m.R, Eigen::ComputeFullU | Eigen::ComputeFullV);
  m.R = svd.matrixU() * svd.matrixV().transpose();
  if (!m.R.allFinite() || !m.t.allFinite()) {
    return absl::InternalError("PnP refinement diverged");
  }
  return m;
}

}  // namespace waymark::visual_slam
