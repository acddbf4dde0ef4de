#ifndef WAYMARK_SERVER_LASER_SLAM_MAPPING_OCCUPANCY_GRID_H_
#define WAYMARK_SERVER_LASER_SLAM_MAPPING_OCCUPANCY_GRID_H_

// The occupancy grid of a session's scans at their optimised poses, in the ROS convention
// (nav_msgs/OccupancyGrid): row-major from the lower-left cell at `origin`, -1 unknown, 0 free ..
// 100 occupied. Every kept scan point is a ray from its node: the cells it crosses gain evidence
// of free space, the cell it ends in evidence of an obstacle (log odds, clamped).

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "absl/status/statusor.h"
#include "server/laser_slam/mapping/mapping_backend.h"
#include "server/laser_slam/mapping/point_cloud.h"

namespace waymark::laser_slam {

struct OccupancyGrid {
  double resolution = 0.05;
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();
  int width = 0;
  int height = 0;
  std::vector<std::int8_t> cells;  // -1 unknown, 0..100

  std::int8_t At(int x, int y) const { return cells[static_cast<size_t>(y) * width + x]; }
};

// The largest grid RenderOccupancy makes (cells); a coarser resolution is needed beyond.
inline constexpr std::int64_t kMaxOccupancyCells = 100'000'000;

// RESOURCE_EXHAUSTED (naming the resolution that would fit) when the map needs more than
// `max_cells` cells (checked before anything is allocated); an empty grid for no nodes.
absl::StatusOr<OccupancyGrid> RenderOccupancy(const std::vector<NodeView>& nodes,
                                              double resolution,
                                              std::int64_t max_cells = kMaxOccupancyCells);

// The finest resolution at or above `resolution` (in whole millimetres) at which the nodes'
// grid has at most `max_cells` cells.
double ResolutionThatFits(const std::vector<NodeView>& nodes, double resolution,
                          std::int64_t max_cells);

// The cells a laser ray crosses from cell `from` to cell `to` (Bresenham): visit(x, y) for every
// cell before `to`, which is left to the caller (the hit). The occupancy grid and the map's
// self-check draw rays alike.
template <typename Visit>
void ForEachCellBefore(const Eigen::Vector2i& from, const Eigen::Vector2i& to, Visit&& visit) {
  int x = from.x(), y = from.y();
  const int dx = to.x() > x ? to.x() - x : x - to.x();
  const int dy = -(to.y() > y ? to.y() - y : y - to.y());
  const int sx = x < to.x() ? 1 : -1, sy = y < to.y() ? 1 : -1;
  int err = dx + dy;
  while (x != to.x() || y != to.y()) {
    visit(x, y);
    const int e2 = 2 * err;
    if (e2 >= dy) {
      err += dy;
      x += sx;
    }
    if (e2 <= dx) {
      err += dx;
      y += sy;
    }
  }
}

// Centres of the occupied cells (value >= occupied), map frame: a grid as a point map.
PointCloud OccupiedPoints(const OccupancyGrid& grid, int occupied = 65);

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_MAPPING_OCCUPANCY_GRID_H_
