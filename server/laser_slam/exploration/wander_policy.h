#ifndef WAYMARK_SERVER_LASER_SLAM_EXPLORATION_WANDER_POLICY_H_
#define WAYMARK_SERVER_LASER_SLAM_EXPLORATION_WANDER_POLICY_H_

// The paper's baseline ("wandering"): drive straight ahead at full speed while the path of one
// observation period is free; otherwise turn in place at full rate towards the side where the last
// scan saw more free space, and keep turning that way until straight ahead is free again (so the
// robot does not dither between left and right in a corner).

#include "server/laser_slam/exploration/clearance.h"
#include "server/laser_slam/exploration/exploration_options.h"
#include "server/laser_slam/exploration/exploration_types.h"
#include "server/laser_slam/exploration/wall_follower.h"

namespace waymark::laser_slam {

class WanderPolicy {
 public:
  explicit WanderPolicy(const ExplorationOptions& options) : options_(options) {}

  Control Choose(const ExplorationView& view, const ClearanceMap& clearance);

 private:
  // +1 (left) or -1 (right): the half of the last scan with the larger mean free range.
  static int OpenerSide(const ExplorationView& view);

  ExplorationOptions options_;
  int turning_ = 0;  // direction of the turn in progress, 0 = driving
};

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_EXPLORATION_WANDER_POLICY_H_
