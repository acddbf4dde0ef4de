#ifndef WAYMARK_SERVER_LASER_SLAM_EXPLORATION_EXPLORATION_GRID_H_
#define WAYMARK_SERVER_LASER_SLAM_EXPLORATION_EXPLORATION_GRID_H_

// What the robot has seen, as a coarse occupancy grid in the planner's frame (the EKF's local
// frame, which a loop closure does not move): the goal layer's frontiers and paths come from it.
//
// Why a grid of its own rather than the back end's (mapping/occupancy_grid.h): the back end keeps
// thinned returns only (no free space where a beam saw nothing within range, which is exactly
// what a frontier is made of), it is asynchronous in the server (a decision must not wait for
// it), and it is absent when loop closure is off (the paper's EKF alone). This grid is updated
// from every scan in place, at a cost linear in the beams, so a decision never re-renders the map.
//
// Cells hold clamped log odds: a return adds `hit`, a beam crossing a cell adds `miss`; a cell is
// occupied above zero, free at or below it, unknown until a beam touched it. The grid grows
// (in whole blocks) to cover every scan.

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "server/laser_slam/types.h"

namespace waymark::laser_slam {

enum class GridCell : std::uint8_t { kUnknown, kFree, kOccupied };

class ExplorationGrid {
 public:
  // `resolution` > 0 (m per cell).
  explicit ExplorationGrid(double resolution);

  // One scan taken with the robot at `robot` and the laser at `laser_pose` on it. A return
  // closer than `max_range` marks its cell occupied and the cells before it free; a beam without
  // a return, or with one beyond max_range, marks free the cells up to `free_range`. The robot's
  // own disc (`body_radius`) is free: it stands there, whatever the laser (which only sees ahead)
  // said of it.
  void Integrate(const Pose2& robot, const Pose2& laser_pose, const LaserScan& scan,
                 double max_range, double free_range, double body_radius);

  double resolution() const { return resolution_; }
  int width() const { return width_; }
  int height() const { return height_; }
  const Eigen::Vector2d& origin() const { return origin_; }  // lower-left corner of cell (0, 0)
  bool empty() const { return width_ == 0; }

  bool Inside(int x, int y) const { return x >= 0 && y >= 0 && x < width_ && y < height_; }
  GridCell At(int x, int y) const;
  int Index(int x, int y) const { return y * width_ + x; }
  Eigen::Vector2i CellOf(const Eigen::Vector2d& point) const;
  Eigen::Vector2d Centre(int x, int y) const;
  Eigen::Vector2d Centre(const Eigen::Vector2i& c) const { return Centre(c.x(), c.y()); }
  // The centre of the cell at grid index `index` (Index(x, y)).
  Eigen::Vector2d CentreOf(int index) const { return Centre(index % width_, index / width_); }

  // Marks a cell (tests and hand-made maps): grows the grid to hold it.
  void Set(const Eigen::Vector2d& point, GridCell cell);

  // Known cells, in square metres (free and occupied).
  double KnownArea() const;

  // Several robots (shared_exploration.h). Every cell unknown here that `other` knows takes its
  // value, `other` placed here by `other_to_this`; the grid grows to hold all of `other`. Cells
  // this grid knows keep their own value: a robot trusts what it saw over another's view through
  // two estimates' error.
  void FillUnknownFrom(const ExplorationGrid& other, const Pose2& other_to_this);
  // Occupied cells whose centres lie within `radius` of `centre` become free (a robot stood
  // there); unknown and free cells are left.
  void FreeOccupiedDisc(const Eigen::Vector2d& centre, double radius);

 private:
  void Cover(const Eigen::Vector2d& lo, const Eigen::Vector2d& hi);
  void Add(int x, int y, int delta);
  void Ray(const Eigen::Vector2d& from, const Eigen::Vector2d& to, bool hit);

  double resolution_;
  Eigen::Vector2d origin_ = Eigen::Vector2d::Zero();
  int width_ = 0;
  int height_ = 0;
  std::vector<std::int8_t> cells_;  // log odds; kUnknownValue when never touched
};

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_EXPLORATION_EXPLORATION_GRID_H_
