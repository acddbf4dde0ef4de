#include "server/laser_slam/exploration/wander_policy.h"

#include <algorithm>
#include <cmath>

namespace waymark::laser_slam {

int WanderPolicy::OpenerSide(const ExplorationView& view) {
  const LaserScan& scan = view.scan;
  double left = 0.0, right = 0.0;
  const int beams = std::min<int>(scan.geometry.beam_count, static_cast<int>(scan.ranges.size()));
  for (int i = 0; i < beams; ++i) {
    const double r = IsReturn(scan.ranges[i], scan.geometry)
                         ? std::min<double>(scan.ranges[i], view.max_range)
                         : view.max_range;
    const double bearing = scan.geometry.angle_min + i * scan.geometry.angle_increment +
                           view.laser_pose.theta;
    (bearing >= 0.0 ? left : right) += r;
  }
  return left >= right ? 1 : -1;
}

Control WanderPolicy::Choose(const ExplorationView& view, const ClearanceMap& clearance) {
  const double required = options_.robot_radius + options_.clearance;
  if (PathIsFree(clearance, options_.max_linear, 0.0, options_.observation_period,
                 options_.control_period, required)) {
    turning_ = 0;
    return Control{options_.max_linear, 0.0};
  }
  if (turning_ == 0) turning_ = OpenerSide(view);
  return Control{0.0, turning_ * options_.max_angular};
}

}  // namespace waymark::laser_slam
