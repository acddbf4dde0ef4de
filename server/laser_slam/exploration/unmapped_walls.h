#ifndef WAYMARK_SERVER_LASER_SLAM_EXPLORATION_UNMAPPED_WALLS_H_
#define WAYMARK_SERVER_LASER_SLAM_EXPLORATION_UNMAPPED_WALLS_H_

// Walls the exploration grid has seen but the segment map has not: occupied cells next to known
// free space farther than `explained` from every mapped segment. A wall seen only at a grazing
// angle (the extraction drops beams below its incidence limit), from far off, or by too few beams
// for a line fit closes the grid's boundary without becoming a segment; the segment map is the
// map the session delivers, so such walls are exploration targets too (look at them squarely),
// and exploring is not done while they remain.

#include <vector>

#include "server/laser_slam/exploration/exploration_grid.h"
#include "server/laser_slam/exploration/frontiers.h"
#include "server/laser_slam/types.h"

namespace waymark::laser_slam {

struct UnmappedWalls {
  std::vector<GridRegion> regions;  // min_cells or more
  std::vector<char> mask;           // grid-sized: 1 on every unmapped wall cell
  int unmapped_cells = 0;  // every region counted
  int mapped_cells = 0;    // boundary cells a segment explains
};

// `segments` in the grid's frame.
UnmappedWalls FindUnmappedWalls(const ExplorationGrid& grid, const std::vector<MapSegment>& segments,
                                double explained, int min_cells);

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_EXPLORATION_UNMAPPED_WALLS_H_
