#include "server/visual_slam/geometry/two_view.h"

#include <cmath>
#include <limits>

namespace waymark::visual_slam {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();

Eigen::Vector3d Homogeneous(const Eigen::Vector2d& p) { return Eigen::Vector3d(p.x(), p.y(), 1); }

}  // namespace

Eigen::Matrix3d Skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d s;
  s << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return s;
}

Eigen::Matrix3d EssentialOf(const Motion& motion) { return Skew(motion.t) * motion.R; }

double SampsonDistance(const Eigen::Matrix3d& E, const Eigen::Vector2d& reference,
                       const Eigen::Vector2d& current) {
  const Eigen::Vector3d xr = Homogeneous(reference), xc = Homogeneous(current);
  const Eigen::Vector3d ex = E * xr, etx = E.transpose() * xc;
  const double e = xc.dot(ex);
  const double den = ex.x() * ex.x() + ex.y() * ex.y() + etx.x() * etx.x() + etx.y() * etx.y();
  if (!(den > 0) || !std::isfinite(e)) return kInf;
  return std::abs(e) / std::sqrt(den);
}

double EpipolarLineDistance(const Eigen::Matrix3d& E, const Eigen::Vector2d& reference,
                            const Eigen::Vector2d& current) {
  const Eigen::Vector3d line = E * Homogeneous(reference);
  const double norm = std::hypot(line.x(), line.y());
  if (!(norm > 0)) return kInf;
  const double d = std::abs(Homogeneous(current).dot(line)) / norm;
  return std::isfinite(d) ? d : kInf;
}

std::optional<Eigen::Vector2d> PairDepths(const Motion& motion, const Eigen::Vector2d& reference,
                                          const Eigen::Vector2d& current) {
  // [R x_r, -x_c] [d_r; d_c] = -t, solved through its 2x2 normal equations.
  Eigen::Matrix<double, 3, 2> A;
  A.col(0) = motion.R * Homogeneous(reference);
  A.col(1) = -Homogeneous(current);
  const Eigen::Matrix2d AtA = A.transpose() * A;
  const double det = AtA.determinant();
  // Parallel rays make the system singular; relative test because the columns have norm >= 1.
  if (!(std::abs(det) > 1e-14 * AtA(0, 0) * AtA(1, 1))) return std::nullopt;
  const Eigen::Vector2d d = AtA.inverse() * (A.transpose() * -motion.t);
  if (!d.allFinite()) return std::nullopt;
  return d;
}

std::optional<Eigen::Vector3d> Triangulate(const Motion& motion, const Eigen::Vector2d& reference,
                                           const Eigen::Vector2d& current,
                                           double min_parallax_rad) {
  const Eigen::Vector3d ray_r = Homogeneous(reference);
  const Eigen::Vector3d ray_c = motion.R.transpose() * Homogeneous(current);  // in reference axes
  const double cos_parallax = ray_r.dot(ray_c) / (ray_r.norm() * ray_c.norm());
  if (!std::isfinite(cos_parallax)) return std::nullopt;
  const double parallax = std::acos(std::min(1.0, std::max(-1.0, cos_parallax)));
  if (!(parallax >= min_parallax_rad)) return std::nullopt;
  const std::optional<Eigen::Vector2d> depths = PairDepths(motion, reference, current);
  if (!depths || (*depths)(0) <= 0 || (*depths)(1) <= 0) return std::nullopt;
  // Midpoint of the closest points of the two rays, in reference coordinates.
  const Eigen::Vector3d on_r = (*depths)(0) * ray_r;
  const Eigen::Vector3d on_c =
      motion.R.transpose() * ((*depths)(1) * Homogeneous(current) - motion.t);
  const Eigen::Vector3d X = 0.5 * (on_r + on_c);
  if (!X.allFinite() || X.z() <= 0 || (motion.R * X + motion.t).z() <= 0) return std::nullopt;
  return X;
}

}  // namespace waymark::visual_slam
