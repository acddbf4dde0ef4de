#ifndef WAYMARK_SERVER_LASER_SLAM_WALL_FOLLOWER_H_
#define WAYMARK_SERVER_LASER_SLAM_WALL_FOLLOWER_H_

// Wall following out of local traps (METHODS.md section 2, steps 1-3):
// 1. Track the nearest mapped segment whose span contains the robot's projection; move along it
//    in the direction with the lower cost to reach unexplored space: the length walked along the
//    chain of adjacent segments until an end that is virtual or has no neighbour (an opening).
// 2. When the robot comes within switch_distance of the tracked segment's end in the direction of
//    travel, track the segment adjacent to that end instead (moving away from the shared end).
// 3. Steer onto the tracking line: the segment's x axis offset by wall_offset towards the robot's
//    side of the wall (the side the robot is on, which for a wall seen from one side is the
//    segment frame's +y here: segments are fitted so that +y faces the sensor that saw them, the
//    opposite of METHODS.md's -y, which assumes the other orientation). Each candidate is scored by
//    the distance of its end pose to a point `lookahead` metres ahead on the tracking line and by
//    the heading error; if no candidate gets closer than standing still, rotate in place.
// Step 4 (leaving the trap when the map grows) is the planner's.

#include <cstdint>
#include <optional>
#include <vector>

#include "server/laser_slam/exploration_options.h"
#include "server/laser_slam/exploration_types.h"

namespace waymark::laser_slam {

struct Control {
  double linear = 0.0;
  double angular = 0.0;
};

class WallFollower {
 public:
  explicit WallFollower(const ExplorationOptions& options) : options_(options) {}

  // Forget the tracked segment (the next Choose picks one afresh).
  void Reset();

  // Picks one of `feasible` (collision-free candidates, each held for observation_period); nullopt
  // when the map has no segment to follow.
  std::optional<Control> Choose(const ExplorationView& view, const std::vector<Control>& feasible);

  std::uint64_t tracked_segment() const { return tracked_; }
  int direction() const { return direction_; }  // +1: towards the right endpoint, -1: left

 private:
  const MapSegment* Find(const std::vector<MapSegment>& segments, std::uint64_t id) const;
  // Step 1.
  bool SelectSegment(const ExplorationView& view);
  // Cost of walking from abscissa `from` on `start` in `direction` to unexplored space.
  double CostToUnexplored(const std::vector<MapSegment>& segments, const MapSegment& start,
                          double from, int direction) const;
  // The segment whose endpoint lies within `adjacency` of `segment`'s end in `direction`, and
  // which of its ends that is (-1 left, +1 right).
  const MapSegment* Adjacent(const std::vector<MapSegment>& segments, const MapSegment& segment,
                             int direction, int* neighbour_end) const;

  ExplorationOptions options_;
  std::uint64_t tracked_ = 0;  // 0 = none
  int direction_ = 1;
};

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_WALL_FOLLOWER_H_
