#ifndef WAYMARK_SERVER_LASER_SLAM_EXPLORATION_WALL_FOLLOWER_H_
#define WAYMARK_SERVER_LASER_SLAM_EXPLORATION_WALL_FOLLOWER_H_

// Wall following out of local traps (METHODS.md section 2, steps 1-3):
// 1. Track the nearest mapped segment whose span contains the robot's projection; move along it
//    in the direction with the lower cost to reach unexplored space: the length walked along the
//    chain of adjacent segments until an end that is virtual or has no neighbour (an opening).
// 2. When the robot comes within switch_distance of the tracked segment's end in the direction of
//    travel, track the segment adjacent to that end instead (moving away from the shared end).
//    When the tracking line runs into another mapped wall (an inner corner, or a thin wall seen
//    from both sides that the first wall meets in its middle), follow that wall instead, away
//    from the first, on the same side. At a real end with no adjacent segment (a doorway, the
//    end of a free-standing wall) go round the end on a half circle to the wall's other side and
//    follow it back there: that is how a wall follower leaves a room. At an outside corner go
//    round the corner onto the next wall's outer face.
// 3. Steer onto the tracking line: the segment's x axis offset by wall_offset towards the robot's
//    side of the wall (the side the robot is on, which for a wall seen from one side is the
//    segment frame's +y here: segments are fitted so that +y faces the sensor that saw them, the
//    opposite of METHODS.md's -y, which assumes the other orientation). Each candidate is scored by
//    the distance of its end pose to a point `lookahead` metres ahead on the tracking line and by
//    the heading error; if no candidate gets closer than standing still, rotate in place (away
//    from the wall, and always the same way until the robot can drive again). A robot that moved
//    less than 0.3 m in 8 decisions turns round along its wall.
// Step 4 (leaving the trap when the map grows) is the planner's.

#include <cmath>
#include <cstdint>
#include <deque>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "server/laser_slam/exploration/exploration_options.h"
#include "server/laser_slam/exploration/exploration_types.h"

namespace waymark::laser_slam {


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
  // Step 3 for one segment: the best candidate, or nullopt when only turning in place back and
  // forth would be left (the line is blocked ahead).
  std::optional<Control> Steer(const ExplorationView& view, const MapSegment& s,
                               const std::vector<Control>& feasible) const;
  // Steering towards a pose (map frame): the feasible control whose end pose is closest to it
  // (distance plus heading error), or nullopt when only turning in place back and forth is left.
  std::optional<Control> SteerTo(const ExplorationView& view, const Pose2& target,
                                 const std::vector<Control>& feasible) const;
  // Going round a wall end or an outside corner at `end` on a circle of radius wall_offset, from
  // the side `n` (unit, from the wall to the robot) past the end (`u`, along the wall) up to the
  // angle `until` (pi: the wall's other side; an outside corner: the next wall's outer face),
  // then following `then_track` in `then_direction`.
  void StartRounding(const Eigen::Vector2d& end, const Eigen::Vector2d& u,
                     const Eigen::Vector2d& n, double until, std::uint64_t then_track,
                     int then_direction);
  // nullopt once round (or when it cannot steer).
  std::optional<Control> Round(const ExplorationView& view, const std::vector<Control>& feasible);
  // The mapped segment the tracking direction runs into within reach, if any.
  const MapSegment* BlockingSegment(const ExplorationView& view, const MapSegment& tracked) const;
  // Step 1.
  bool SelectSegment(const ExplorationView& view);
  // Cost of walking from abscissa `from` on `start` in `direction` to unexplored space.
  // `away` points from the wall to the robot's side.
  double CostToUnexplored(const std::vector<MapSegment>& segments, const MapSegment& start,
                          double from, int direction, const Eigen::Vector2d& away) const;
  // The segment met within `adjacency` of `segment`'s end in `direction` and the direction to
  // follow it in: at an L corner (one of its ends is there) leave it by its other end; at a T
  // junction (it passes there) go along it towards `away`, the robot's side of `segment`.
  const MapSegment* Adjacent(const std::vector<MapSegment>& segments, const MapSegment& segment,
                             int direction, const Eigen::Vector2d& away,
                             int* next_direction) const;
  // Unit normal of `s` pointing to the robot's side.
  static Eigen::Vector2d AwayFromWall(const MapSegment& s, const Pose2& robot);

  ExplorationOptions options_;
  std::uint64_t tracked_ = 0;  // 0 = none
  int direction_ = 1;
  int turning_ = 0;                     // sticky rotation in place, 0 = none
  std::deque<Eigen::Vector2d> recent_;  // robot positions at the last decisions
  bool rounding_ = false;               // going round a wall end (Round)
  Eigen::Vector2d round_end_ = Eigen::Vector2d::Zero();  // the end being rounded
  Eigen::Vector2d round_u_ = Eigen::Vector2d::UnitX();   // along the wall, past the end
  Eigen::Vector2d round_n_ = Eigen::Vector2d::UnitY();   // from the wall to the side we came on
  double round_until_ = M_PI;
  std::uint64_t round_next_ = 0;
  int round_next_direction_ = 1;
};

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_EXPLORATION_WALL_FOLLOWER_H_
