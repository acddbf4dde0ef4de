#ifndef WAYMARK_SERVER_LASER_SLAM_EXPLORATION_PATH_FOLLOWING_H_
#define WAYMARK_SERVER_LASER_SLAM_EXPLORATION_PATH_FOLLOWING_H_

// Helpers for following a grid path with the planner's own candidate controls (go-stop: one
// control held for one observation period); the rating itself is the planner's
// (ExplorationPlanner::FollowTarget).

#include <vector>

#include <Eigen/Core>

#include "server/laser_slam/exploration/exploration_types.h"
#include "server/laser_slam/types.h"

namespace waymark::laser_slam {

// The point `lookahead` metres along `path` past its point nearest `robot` (the path's end when
// it is shorter). `path` must not be empty.
Eigen::Vector2d LookaheadPoint(const std::vector<Eigen::Vector2d>& path, const Eigen::Vector2d& robot,
                               double lookahead);

// The bearing of `aim` seen from `from`, relative to its heading (rad, in [-pi, pi]); 0 when
// `aim` is where `from` stands.
double BearingError(const Pose2& from, const Eigen::Vector2d& aim);

// The turn in place among `candidates` that leaves the robot facing `aim` most nearly after
// `seconds`, or nullptr when none turns in place.
const Control* TurnTowards(const Pose2& robot, const Eigen::Vector2d& aim,
                           const std::vector<Control>& candidates, double seconds);

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_EXPLORATION_PATH_FOLLOWING_H_
