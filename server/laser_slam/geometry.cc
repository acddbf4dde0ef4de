#include "server/laser_slam/geometry.h"

namespace waymark::laser_slam {

Eigen::Matrix3d ComposeJacobianFirst(const Pose2& a, const Pose2& b) {
  const double c = std::cos(a.theta), s = std::sin(a.theta);
  Eigen::Matrix3d j = Eigen::Matrix3d::Identity();
  j(0, 2) = -s * b.x - c * b.y;
  j(1, 2) = c * b.x - s * b.y;
  return j;
}

Eigen::Matrix3d ComposeJacobianSecond(const Pose2& a, const Pose2& /*b*/) {
  const double c = std::cos(a.theta), s = std::sin(a.theta);
  Eigen::Matrix3d j = Eigen::Matrix3d::Identity();
  j(0, 0) = c;
  j(0, 1) = -s;
  j(1, 0) = s;
  j(1, 1) = c;
  return j;
}

Eigen::Matrix3d InvertJacobian(const Pose2& a) {
  const double c = std::cos(a.theta), s = std::sin(a.theta);
  Eigen::Matrix3d j;
  j << -c, -s, s * a.x - c * a.y,  //
      s, -c, c * a.x + s * a.y,    //
      0, 0, -1;
  return j;
}

}  // namespace waymark::laser_slam
