#include "server/laser_slam/motion.h"

#include <cmath>

#include "server/laser_slam/sp_jacobians.h"

namespace waymark::laser_slam {
namespace {
double Sq(double v) { return v * v; }
}  // namespace

Eigen::Matrix3d IncrementNoise(const Pose2& u, const OdometryNoise& noise) {
  const double distance = std::hypot(u.x, u.y);
  const double turn = std::abs(u.theta);
  const double sxy = noise.xy_min + noise.xy_per_m * distance;
  const double sth = noise.theta_min + noise.theta_per_rad * turn + noise.theta_per_m * distance;
  return Eigen::Vector3d(Sq(sxy), Sq(sxy), Sq(sth)).asDiagonal();
}

Pose2 UnicycleArc(double linear, double angular, double seconds) {
  const double turn = angular * seconds;
  if (std::abs(turn) < 1e-9) return Pose2{linear * seconds, 0.0, 0.0};
  const double radius = linear / angular;
  return Pose2{radius * std::sin(turn), radius * (1.0 - std::cos(turn)), turn};
}

Eigen::Matrix3d PredictRobotCovariance(const Eigen::Matrix3d& covariance, const Pose2& u,
                                       const OdometryNoise& noise) {
  const Eigen::Matrix3d f = PredictionJacobian(u);
  return f * covariance * f.transpose() + IncrementNoise(u, noise);
}

}  // namespace waymark::laser_slam
