#ifndef WAYMARK_SERVER_LASER_SLAM_EXPLORATION_CLEARANCE_H_
#define WAYMARK_SERVER_LASER_SLAM_EXPLORATION_CLEARANCE_H_

// Collision checking for suggested controls. The obstacles are the last scan's returns (exact
// relative to the robot, whatever the map's error) and the mapped segments near the robot (which
// also cover what the laser cannot see behind it), both in the robot frame at the decision.

#include <vector>

#include <Eigen/Core>

#include "server/laser_slam/exploration/exploration_types.h"

namespace waymark::laser_slam {

class ClearanceMap {
 public:
  // Keeps the obstacles within `reach` of the robot (the path length plus the body, say).
  // `more` are further obstacle points in the map frame (the exploration grid's occupied cells:
  // walls beside or behind the robot that the laser, which sees ahead, and the segment map, which
  // lacks walls seen only at grazing angles, do not show).
  ClearanceMap(const ExplorationView& view, double reach,
               const std::vector<Eigen::Vector2d>& more = {});

  // Distance from `p` (robot frame) to the nearest obstacle; `reach` when there is none nearer.
  double Distance(const Eigen::Vector2d& p) const;

  int obstacle_points() const { return static_cast<int>(points_.size()); }
  int obstacle_segments() const { return static_cast<int>(segments_.size()); }

 private:
  double reach_;
  std::vector<Eigen::Vector2d> points_;
  std::vector<std::pair<Eigen::Vector2d, Eigen::Vector2d>> segments_;
};

// Whether holding (linear, angular) for `seconds` keeps the robot's centre at least `required`
// from every obstacle, checked every `step` seconds along the arc. A robot that already stands
// closer than `required` may move as long as it gets no closer than it is (so it can turn away
// or back out of a tight spot instead of freezing).
bool PathIsFree(const ClearanceMap& map, double linear, double angular, double seconds, double step,
                double required);

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_EXPLORATION_CLEARANCE_H_
