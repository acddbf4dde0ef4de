#ifndef WAYMARK_SERVER_LASER_SLAM_GEOMETRY_H_
#define WAYMARK_SERVER_LASER_SLAM_GEOMETRY_H_

// 2-D location algebra of the SP model: composition (+), inversion, their Jacobians.
// The templates take any scalar (double, or Eigen's AutoDiffScalar for exact Jacobians of the
// composite measurement functions in ekf_*.cc).

#include <algorithm>
#include <cmath>

#include <Eigen/Core>

#include "server/laser_slam/types.h"

namespace waymark::laser_slam {

template <typename T>
using Vec3 = Eigen::Matrix<T, 3, 1>;

// Wraps an angle to (-pi, pi].
inline double NormalizeAngle(double a) {
  a = std::fmod(a + M_PI, 2.0 * M_PI);
  if (a <= 0.0) a += 2.0 * M_PI;
  return a - M_PI;
}

// The same segment (ObservedSegment, MapSegment) described from its other end: frame turned by
// pi, endpoints swapped. p_y changes sign with the frame's y axis; p_theta does not.
template <class Segment>
Segment Flipped(const Segment& s) {
  Segment f = s;
  f.frame.theta = NormalizeAngle(s.frame.theta + M_PI);
  f.left = -s.right;
  f.right = -s.left;
  f.left_type = s.right_type;
  f.right_type = s.left_type;
  f.left_variance = s.right_variance;
  f.right_variance = s.left_variance;
  f.line_covariance(0, 1) = -s.line_covariance(0, 1);
  f.line_covariance(1, 0) = -s.line_covariance(1, 0);
  return f;
}

// Euclidean distance from p to the segment [a, b] (to a when the segment has zero length).
inline double PointSegmentDistance(const Eigen::Vector2d& p, const Eigen::Vector2d& a,
                                   const Eigen::Vector2d& b) {
  const Eigen::Vector2d ab = b - a;
  const double length2 = ab.squaredNorm();
  const double t = length2 > 0.0 ? std::clamp((p - a).dot(ab) / length2, 0.0, 1.0) : 0.0;
  return (a + t * ab - p).norm();
}

// a (+) b: the location b, given relative to frame a, expressed in a's parent frame.
template <typename T>
Vec3<T> Compose(const Vec3<T>& a, const Vec3<T>& b) {
  using std::cos;
  using std::sin;
  const T c = cos(a(2)), s = sin(a(2));
  return Vec3<T>(a(0) + c * b(0) - s * b(1), a(1) + s * b(0) + c * b(1), a(2) + b(2));
}

// (-)a: the parent frame seen from a.
template <typename T>
Vec3<T> Invert(const Vec3<T>& a) {
  using std::cos;
  using std::sin;
  const T c = cos(a(2)), s = sin(a(2));
  return Vec3<T>(-c * a(0) - s * a(1), s * a(0) - c * a(1), -a(2));
}

inline Eigen::Vector3d ToVector(const Pose2& p) { return Eigen::Vector3d(p.x, p.y, p.theta); }
inline bool FinitePose(const Pose2& p) {
  return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.theta);
}
inline Pose2 ToPose(const Eigen::Vector3d& v) { return Pose2{v(0), v(1), NormalizeAngle(v(2))}; }

// Pose2 versions: angles of the result are normalised.
inline Pose2 Compose(const Pose2& a, const Pose2& b) {
  return ToPose(Compose<double>(ToVector(a), ToVector(b)));
}
inline Pose2 Invert(const Pose2& a) { return ToPose(Invert<double>(ToVector(a))); }
// The location of b in frame a: (-)a (+) b.
inline Pose2 Relative(const Pose2& a, const Pose2& b) { return Compose(Invert(a), b); }
// A point `from` (the frame `to_here` maps from) moved by `to_here`.
inline Eigen::Vector2d MoveBy(const Pose2& to_here, const Eigen::Vector2d& from) {
  const Pose2 p = Compose(to_here, Pose2{from.x(), from.y(), 0.0});
  return Eigen::Vector2d(p.x, p.y);
}

// d(a (+) b)/da and d(a (+) b)/db (the SP model's J1{+} and J2{+}).
Eigen::Matrix3d ComposeJacobianFirst(const Pose2& a, const Pose2& b);
Eigen::Matrix3d ComposeJacobianSecond(const Pose2& a, const Pose2& b);
// d((-)a)/da.
Eigen::Matrix3d InvertJacobian(const Pose2& a);

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_GEOMETRY_H_
