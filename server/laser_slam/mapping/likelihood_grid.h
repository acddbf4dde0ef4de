#ifndef WAYMARK_SERVER_LASER_SLAM_MAPPING_LIKELIHOOD_GRID_H_
#define WAYMARK_SERVER_LASER_SLAM_MAPPING_LIKELIHOOD_GRID_H_

// A likelihood field: for every cell, how likely a laser return is there (255 on a mapped point,
// falling as a Gaussian of the distance to the nearest one). Scan matching scores a pose by the
// mean value under the scan's points. One byte per cell keeps a 20 m x 20 m submap at 5 cm in
// 160 kB.

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "server/laser_slam/mapping/point_cloud.h"

namespace waymark::laser_slam {

struct LikelihoodGrid {
  double resolution = 0.05;
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();  // corner of cell (0, 0), grid frame
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> cells;  // row-major, y rows

  bool empty() const { return cells.empty(); }
  std::uint8_t At(int x, int y) const {
    return x < 0 || y < 0 || x >= width || y >= height ? 0 : cells[static_cast<size_t>(y) * width + x];
  }
  // Bilinear value in [0, 1] at a point of the grid frame.
  double Interpolate(double px, double py) const;
};

// The most cells a search grid may have (16 MB, a 200 m square at 5 cm): a submap or a local map
// spans a few tens of metres. Only corrupt or hostile input spreads one over more: points a
// kilometre apart in a restored checkpoint made one grid of 10^9 cells (found by make fuzz).
inline constexpr std::int64_t kMaxSearchGridCells = 16'000'000;

// The field of `points` (grid frame) with Gaussian spread `sigma`, margin 3 sigma around them.
// An empty grid (nothing matches against it) when that takes more than `max_cells` cells.
LikelihoodGrid BuildLikelihoodGrid(const PointCloud& points, double resolution, double sigma,
                                   std::int64_t max_cells = kMaxSearchGridCells);

// Max-pooled copies of a grid for branch and bound: level d holds, at cell (x, y), the largest
// value of the base cells [x, x + 2^d) x [y, y + 2^d); cells left of and below the grid are
// included (offset 2^d - 1) so that every candidate window has a cell.
class SearchPyramid {
 public:
  SearchPyramid(const LikelihoodGrid& grid, int depth);
  int depth() const { return static_cast<int>(levels_.size()) - 1; }
  std::uint8_t At(int level, int x, int y) const {
    const Level& l = levels_[level];
    x += l.offset;
    y += l.offset;
    return x < 0 || y < 0 || x >= l.width || y >= l.height
               ? 0
               : l.cells[static_cast<size_t>(y) * l.width + x];
  }
  const LikelihoodGrid& base() const { return base_; }

 private:
  struct Level {
    int offset = 0;
    int width = 0;
    int height = 0;
    std::vector<std::uint8_t> cells;
  };
  LikelihoodGrid base_;
  std::vector<Level> levels_;
};

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_MAPPING_LIKELIHOOD_GRID_H_
