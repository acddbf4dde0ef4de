#ifndef WAYMARK_SERVER_LASER_SLAM_EXPLORATION_SHARED_EXPLORATION_H_
#define WAYMARK_SERVER_LASER_SLAM_EXPLORATION_SHARED_EXPLORATION_H_

// Several robots exploring one map (issue 38): what the goal layer of one robot knows of the
// others. Each robot publishes a snapshot of its exploration after every decision; the service
// (server/service/slam/exploration_team.h) hands every tied-in robot of a map the snapshots of the
// others with the transform from their planner frames into its own. Plain values: no gRPC, no
// store, no threads here (a snapshot is immutable once published, shared by pointer).
//
// What the goal layer does with them (goal_layer.h): it decides on its own grid with the unknown
// cells filled from the others' grids (a frontier another robot already closed is no frontier),
// their segments count as mapped walls, the cells where they stood are free (a robot the laser
// saw is not a wall), a target another robot looked at from its goal and found still open is
// given up, and a target near one another robot claimed is penalised unless this robot is the
// nearer one, so that the robots spread over the floor.

#include <memory>
#include <optional>
#include <vector>

#include <Eigen/Core>

#include "server/laser_slam/exploration/exploration_grid.h"
#include "server/laser_slam/types.h"

namespace waymark::laser_slam {

// One robot's exploration as it stood after its last decision, in its planner frame.
struct ExplorationSnapshot {
  ExplorationGrid grid{0.1};          // its own exploration grid (its scans only)
  std::vector<MapSegment> segments;   // its segment map
  Pose2 robot;                        // where it is
  std::vector<Eigen::Vector2d> stood; // where it has stood (at decisions, thinned)
  std::optional<Eigen::Vector2d> claim;  // what its current target looks at, if it has one
  // Targets it reached, faced and found still open: beyond a robot's reach or its laser's, so
  // given up by every robot of the map (not those it gave up for lack of progress: another
  // robot, elsewhere, may get closer).
  std::vector<Eigen::Vector2d> looked_at_open;
  bool finished = false;              // DONE or STUCK
  // Its planner frame in its session's frame (the back end's correction at that scan): the
  // service moves the snapshot on into the map frame with the session's origin.
  Pose2 local_to_session;
};

// Another robot of the same map, as one robot's goal layer sees it.
struct Teammate {
  std::shared_ptr<const ExplorationSnapshot> snapshot;
  // The teammate's planner frame in this robot's frame: its session frame for what the service
  // hands over, its planner frame once LaserSlam moved it there (ExplorationView::teammates).
  Pose2 to_here;
};

// The grid a decision uses: `grid` with the teammates' knowledge merged into it. Cells this robot
// knows keep their value; unknown ones take the teammate's; occupied cells within `body_radius`
// of a place a teammate stood become free.
void MergeTeammates(const std::vector<Teammate>& teammates, double body_radius,
                    ExplorationGrid* grid);

// Every teammate's segments moved into this robot's frame, after `own`.
std::vector<MapSegment> WithTeammateSegments(const std::vector<MapSegment>& own,
                                             const std::vector<Teammate>& teammates);

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_EXPLORATION_SHARED_EXPLORATION_H_
