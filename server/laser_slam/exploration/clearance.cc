#include "server/laser_slam/exploration/clearance.h"

#include <algorithm>
#include <cmath>

#include "server/laser_slam/geometry.h"
#include "server/laser_slam/motion.h"

namespace waymark::laser_slam {
namespace {

Eigen::Vector2d ToRobot(const Pose2& robot, const Pose2& point_in_map) {
  const Pose2 local = Relative(robot, point_in_map);
  return Eigen::Vector2d(local.x, local.y);
}

}  // namespace

ClearanceMap::ClearanceMap(const ExplorationView& view, double reach,
                           const std::vector<Eigen::Vector2d>& more)
    : reach_(reach) {
  for (const Eigen::Vector2d& m : more) {
    const Eigen::Vector2d p = ToRobot(view.robot, Pose2{m.x(), m.y(), 0.0});
    if (p.norm() <= reach) points_.push_back(p);
  }
  const LaserScan& scan = view.scan;
  const int beams = std::min<int>(scan.geometry.beam_count, static_cast<int>(scan.ranges.size()));
  for (int i = 0; i < beams; ++i) {
    const double r = scan.ranges[i];
    if (!IsReturn(r, scan.geometry)) continue;
    const double bearing = scan.geometry.angle_min + i * scan.geometry.angle_increment;
    const Pose2 hit = Compose(view.laser_pose, Pose2{r * std::cos(bearing), r * std::sin(bearing), 0});
    const Eigen::Vector2d p(hit.x, hit.y);
    if (p.norm() <= reach) points_.push_back(p);
  }
  for (const MapSegment& s : view.segments) {
    const Eigen::Vector2d a = ToRobot(view.robot, Compose(s.frame, Pose2{s.left, 0, 0}));
    const Eigen::Vector2d b = ToRobot(view.robot, Compose(s.frame, Pose2{s.right, 0, 0}));
    if (PointSegmentDistance(Eigen::Vector2d::Zero(), a, b) <= reach) segments_.emplace_back(a, b);
  }
}

double ClearanceMap::Distance(const Eigen::Vector2d& p) const {
  double best = reach_;
  for (const Eigen::Vector2d& q : points_) best = std::min(best, (q - p).norm());
  for (const auto& [a, b] : segments_) best = std::min(best, PointSegmentDistance(p, a, b));
  return best;
}

bool PathIsFree(const ClearanceMap& map, double linear, double angular, double seconds, double step,
                double required) {
  const double start = map.Distance(Eigen::Vector2d::Zero());
  const double floor = std::min(required, start) - 1e-9;
  if (linear == 0.0) return true;  // turning in place does not move the centre
  const int steps = std::max(1, static_cast<int>(std::ceil(seconds / step - 1e-9)));
  for (int k = 1; k <= steps; ++k) {
    const Pose2 at = UnicycleArc(linear, angular, std::min(seconds, k * step));
    if (map.Distance(Eigen::Vector2d(at.x, at.y)) < floor) return false;
  }
  return true;
}

}  // namespace waymark::laser_slam
