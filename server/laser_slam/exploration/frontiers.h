#ifndef WAYMARK_SERVER_LASER_SLAM_EXPLORATION_FRONTIERS_H_
#define WAYMARK_SERVER_LASER_SLAM_EXPLORATION_FRONTIERS_H_

// Frontiers (Yamauchi 1997): known free cells with an unknown 4-neighbour, the boundary between
// what the robot has seen and what it has not. An unknown cell next to an occupied one does not
// count: it is a gap in a mapped wall (a wall seen at a grazing angle is hit in some cells and
// crossed by rays in others), not open space. Adjacent frontier cells (8-connected) form one
// region; regions shorter than `min_cells` are dropped (a beam slipping past a corner leaves a
// few such cells, and no robot could look through that gap anyway).

#include <vector>

#include <Eigen/Core>

#include "server/laser_slam/exploration/exploration_grid.h"

namespace waymark::laser_slam {

// Cells of the grid that belong together (8-connected).
struct GridRegion {
  std::vector<int> cells;  // grid indices
  Eigen::Vector2d centroid = Eigen::Vector2d::Zero();
  double length = 0.0;  // m: cells x resolution
};

struct Frontiers {
  std::vector<GridRegion> regions;  // min_cells or more
  std::vector<char> mask;  // grid-sized: 1 on every frontier cell
  int open_cells = 0;    // frontier cells, every region counted
  int closed_cells = 0;  // occupied cells next to known free space: the mapped boundary
  // Share of the known free space's boundary still open: open / (open + closed).
  double OpenShare() const {
    const int all = open_cells + closed_cells;
    return all > 0 ? static_cast<double>(open_cells) / all : 1.0;
  }
};

Frontiers FindFrontiers(const ExplorationGrid& grid, int min_cells);

// Whether a cell within `radius` of `point` is marked in `mask` (grid-sized).
bool MaskedNear(const ExplorationGrid& grid, const std::vector<char>& mask,
                const Eigen::Vector2d& point, double radius);

// The 8-connected regions of the cells marked 1 in `mask` (grid-sized), of min_cells or more.
std::vector<GridRegion> ConnectedRegions(const ExplorationGrid& grid, std::vector<char> mask,
                                         int min_cells);

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_EXPLORATION_FRONTIERS_H_
