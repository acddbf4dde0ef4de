#ifndef WAYMARK_SERVER_LASER_SLAM_EXPLORATION_GRID_PATHS_H_
#define WAYMARK_SERVER_LASER_SLAM_EXPLORATION_GRID_PATHS_H_

// Paths through mapped free space on the exploration grid: a cell is traversable when it is known
// free and the robot's disc plus its clearance fits there (distance to the nearest occupied cell);
// unknown cells are never entered. Steps near walls cost more (up to `wall_penalty` extra per
// metre at the clearance limit, nothing beyond `comfort_distance`), so paths keep to the middle of
// corridors and doorways, where the local controller's arc check has room.
//
// One Dijkstra from the robot serves every target of a decision (their costs and paths), so it
// costs one pass over the grid whatever the number of targets.

#include <vector>

#include <Eigen/Core>

#include "server/laser_slam/exploration/exploration_grid.h"

namespace waymark::laser_slam {

struct PathOptions {
  double required_distance = 0.4;  // m: robot radius + clearance
  double comfort_distance = 0.8;   // m
  double wall_penalty = 2.0;       // extra cost per metre at required_distance
  // Around the robot (escape_centre), known free cells are traversable even when closer to a
  // wall than required, as long as they are no closer than the robot's own cell (less half a cell
  // for the rounding): the robot may stand there (the clearance rules let it) and must be able to
  // leave, but only the way the collision check lets it, by getting no closer to the wall.
  Eigen::Vector2d escape_centre = Eigen::Vector2d::Zero();
  double escape_radius = 0.5;  // m
  // Stop the search once the cell of `stop_near` is settled and every cell up to `stop_margin`
  // (in cost) beyond it too (0: search the whole grid). A field from a goal needs only the cells
  // the robot's next controls can end in and the path between them and the goal, all of which
  // cost less than that.
  Eigen::Vector2d stop_near = Eigen::Vector2d::Zero();
  double stop_margin = 0.0;
};

// Distance (m) from each cell's centre to the nearest occupied cell, capped at `cap` (8-connected
// chamfer distance: within 8 % of the Euclidean one).
std::vector<float> ObstacleDistance(const ExplorationGrid& grid, float cap);

class CostField {
 public:
  // Dijkstra from the cell of `start` over traversable cells. `distance` is ObstacleDistance of
  // `grid`; both must outlive the field. Paths are symmetric: a field from a goal gives every
  // cell's cost to reach it, and following parents from a cell leads to the goal.
  CostField(const ExplorationGrid& grid, const std::vector<float>& distance,
            const Eigen::Vector2d& start, const PathOptions& options);

  bool Traversable(int index) const;
  bool Reachable(int index) const { return cost_[index] < kUnreached; }
  double Cost(int index) const { return cost_[index]; }
  double Length(int index) const { return length_[index]; }  // m along the path
  // Cell centres from the start to the cell (the start first); empty when unreachable.
  std::vector<Eigen::Vector2d> PathTo(int index) const;
  // The cell of `point`, or -1 outside the grid.
  int CellIndex(const Eigen::Vector2d& point) const;
  // Parent of a reached cell (towards the start); -1 at the start.
  int Parent(int index) const { return parent_[index]; }
  const ExplorationGrid& grid() const { return grid_; }

  static constexpr float kUnreached = 1e30f;

 private:
  const ExplorationGrid& grid_;
  const std::vector<float>& distance_;
  PathOptions options_;
  float escape_floor_ = 0.0f;  // distance to walls an escape cell needs
  std::vector<float> cost_;
  std::vector<float> length_;
  std::vector<int> parent_;
};

// One path from `from` to `to` (cell centres, `from`'s cell first); empty when `to` cannot be
// reached through traversable cells.
std::vector<Eigen::Vector2d> PlanPath(const ExplorationGrid& grid, const Eigen::Vector2d& from,
                                      const Eigen::Vector2d& to, const PathOptions& options);

// Arc length of a polyline.
double PathLength(const std::vector<Eigen::Vector2d>& path);

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_EXPLORATION_GRID_PATHS_H_
