#include "server/laser_slam/sp_jacobians.h"

#include <unsupported/Eigen/AutoDiff>

#include "server/laser_slam/geometry.h"

namespace waymark::laser_slam {
namespace {

template <int N>
using Ad = Eigen::AutoDiffScalar<Eigen::Matrix<double, N, 1>>;

template <int N>
Vec3<Ad<N>> Constant(const Pose2& p) {
  return Vec3<Ad<N>>(Ad<N>(p.x), Ad<N>(p.y), Ad<N>(p.theta));
}

// Seeds variable `index` of N with value 0.
template <int N>
Ad<N> Variable(int index) {
  return Ad<N>(0.0, N, index);
}

}  // namespace

RelativeLine RelateLines(const Pose2& s, const Pose2& p, const Pose2& q) {
  constexpr int N = 7;  // a_y a_theta | b_x b_y b_theta | c_y c_theta
  using T = Ad<N>;
  const Vec3<T> a(T(0.0), Variable<N>(0), Variable<N>(1));
  const Vec3<T> b(Variable<N>(2), Variable<N>(3), Variable<N>(4));
  const Vec3<T> c(T(0.0), Variable<N>(5), Variable<N>(6));
  const Vec3<T> line_s = Compose<T>(Constant<N>(s), a);
  const Vec3<T> line_o = Compose<T>(Compose<T>(Compose<T>(Constant<N>(p), b), Constant<N>(q)), c);
  const Vec3<T> z = Compose<T>(Invert<T>(line_s), line_o);
  RelativeLine out;
  Eigen::Matrix<double, 3, N> j;
  for (int r = 0; r < 3; ++r) {
    out.z(r) = z(r).value();
    j.row(r) = z(r).derivatives().transpose();
  }
  out.z(2) = NormalizeAngle(out.z(2));
  out.d_a = j.leftCols<2>();
  out.d_b = j.middleCols<3>(2);
  out.d_c = j.rightCols<2>();
  return out;
}

Eigen::Matrix3d PredictionJacobian(const Pose2& u) {
  using T = Ad<3>;
  const Vec3<T> d(Variable<3>(0), Variable<3>(1), Variable<3>(2));
  const Vec3<T> uu = Constant<3>(u);
  const Vec3<T> out = Compose<T>(Compose<T>(Invert<T>(uu), d), uu);
  Eigen::Matrix3d j;
  for (int r = 0; r < 3; ++r) j.row(r) = out(r).derivatives().transpose();
  return j;
}

Eigen::Matrix3d RobotCenteringJacobian(const Eigen::Vector3d& delta) {
  using T = Ad<3>;
  const Vec3<T> d(T(delta(0), 3, 0), T(delta(1), 3, 1), T(delta(2), 3, 2));
  const Vec3<T> del(T(delta(0)), T(delta(1)), T(delta(2)));
  const Vec3<T> out = Compose<T>(Invert<T>(del), d);
  Eigen::Matrix3d j;
  for (int r = 0; r < 3; ++r) j.row(r) = out(r).derivatives().transpose();
  return j;
}

Eigen::Matrix2d LineCenteringJacobian(const Eigen::Vector2d& delta) {
  using T = Ad<2>;
  using std::tan;
  const Vec3<T> p(T(0.0), T(delta(0), 2, 0), T(delta(1), 2, 1));
  const Vec3<T> del(T(0.0), T(delta(0)), T(delta(1)));
  const Vec3<T> rel = Compose<T>(Invert<T>(del), p);
  // Re-express the relative frame (x, y, theta) as a line with its intercept at x = 0.
  const T intercept = rel(1) - rel(0) * tan(rel(2));
  Eigen::Matrix2d j;
  j.row(0) = intercept.derivatives().transpose();
  j.row(1) = rel(2).derivatives().transpose();
  return j;
}

Eigen::Matrix2d LineShiftJacobian(double shift) {
  Eigen::Matrix2d j = Eigen::Matrix2d::Identity();
  j(0, 1) = shift;
  return j;
}

}  // namespace waymark::laser_slam
