#include "server/laser_slam/exploration/path_following.h"

#include <cmath>
#include <limits>

#include "server/laser_slam/geometry.h"

namespace waymark::laser_slam {
double BearingError(const Pose2& from, const Eigen::Vector2d& aim) {
  const Eigen::Vector2d d = aim - Eigen::Vector2d(from.x, from.y);
  if (d.norm() < 1e-9) return 0.0;
  return NormalizeAngle(std::atan2(d.y(), d.x()) - from.theta);
}

Eigen::Vector2d LookaheadPoint(const std::vector<Eigen::Vector2d>& path, const Eigen::Vector2d& robot,
                               double lookahead) {
  size_t nearest = 0;
  for (size_t i = 1; i < path.size(); ++i) {
    if ((path[i] - robot).norm() < (path[nearest] - robot).norm()) nearest = i;
  }
  double left = lookahead;
  for (size_t i = nearest; i + 1 < path.size(); ++i) {
    const double step = (path[i + 1] - path[i]).norm();
    if (step >= left) return path[i] + (path[i + 1] - path[i]) * (left / step);
    left -= step;
  }
  return path.back();
}

const Control* TurnTowards(const Pose2& robot, const Eigen::Vector2d& aim,
                           const std::vector<Control>& candidates, double seconds) {
  const double error = BearingError(robot, aim);
  const Control* best = nullptr;
  double best_left = std::numeric_limits<double>::infinity();
  for (const Control& c : candidates) {
    if (c.linear != 0.0 || c.angular == 0.0) continue;
    const double left = std::abs(error - c.angular * seconds);
    if (left < best_left) {
      best_left = left;
      best = &c;
    }
  }
  return best;
}

}  // namespace waymark::laser_slam
