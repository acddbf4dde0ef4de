#ifndef WAYMARK_SERVER_LASER_SLAM_MAPPING_LIKELIHOOD_GRID_H_
#define WAYMARK_SERVER_LASER_SLAM_MAPPING_LIKELIHOOD_GRID_H_

// A likelihood field: for every cell, how likely a laser return is there (255 on a mapped point,
// falling as a Gaussian of the distance to the nearest one). Scan matching scores a pose by the
// mean value under the scan's points. One byte per cell keeps a 20 m x 20 m submap at 5 cm in
// 160 kB.

#include <cmath>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "server/laser_slam/mapping/point_cloud.h"

namespace waymark::laser_slam {

struct LikelihoodGrid {
  double resolution = 0.05;
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();  // corner of cell (0, 0), grid frame
  // The cells stored: columns [x0, x0 + width), rows [y0, y0 + height) of the lattice anchored at
  // `origin` (0 but for a window cut out of a larger grid: GridFrame below).
  int x0 = 0;
  int y0 = 0;
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> cells;  // row-major, y rows

  bool empty() const { return cells.empty(); }
  std::uint8_t At(int x, int y) const {
    x -= x0;
    y -= y0;
    return x < 0 || y < 0 || x >= width || y >= height ? 0 : cells[static_cast<size_t>(y) * width + x];
  }
  // Bilinear value in [0, 1] at a point of the grid frame (inline: scan matching's refinement
  // calls it for every point of hundreds of poses).
  double Interpolate(double px, double py) const;
  // The same from the cell below-left of the point, (ix, iy), and the point's place in the square
  // of cell centres from there, (fx, fy) in [0, 1): Interpolate with its divisions done.
  double Bilinear(int ix, int iy, double fx, double fy) const;
};

inline double LikelihoodGrid::Interpolate(double px, double py) const {
  const double gx = (px - origin.x()) / resolution - 0.5;
  const double gy = (py - origin.y()) / resolution - 0.5;
  const int ix = static_cast<int>(std::floor(gx)), iy = static_cast<int>(std::floor(gy));
  return Bilinear(ix, iy, gx - ix, gy - iy);
}

inline double LikelihoodGrid::Bilinear(int ix, int iy, double fx, double fy) const {
  double v00, v10, v01, v11;
  const int sx = ix - x0, sy = iy - y0;
  if (sx >= 0 && sy >= 0 && sx + 1 < width && sy + 1 < height) {
    const std::uint8_t* c = cells.data() + static_cast<size_t>(sy) * width + sx;
    v00 = c[0];
    v10 = c[1];
    v01 = c[width];
    v11 = c[width + 1];
  } else {
    v00 = At(ix, iy);
    v10 = At(ix + 1, iy);
    v01 = At(ix, iy + 1);
    v11 = At(ix + 1, iy + 1);
  }
  const double v = (1 - fx) * (1 - fy) * v00 + fx * (1 - fy) * v10 + (1 - fx) * fy * v01 +
                   fx * fy * v11;
  return v / 255.0;
}

// The most cells a search grid may have (16 MB, a 200 m square at 5 cm): a submap or a local map
// spans a few tens of metres. Only corrupt or hostile input spreads one over more: points a
// kilometre apart in a restored checkpoint made one grid of 10^9 cells (found by make fuzz).
inline constexpr std::int64_t kMaxSearchGridCells = 16'000'000;

// The field of `points` (grid frame) with Gaussian spread `sigma`, margin 3 sigma around them.
// An empty grid (nothing matches against it) when that takes more than `max_cells` cells.
LikelihoodGrid BuildLikelihoodGrid(const PointCloud& points, double resolution, double sigma,
                                   std::int64_t max_cells = kMaxSearchGridCells);

// The lattice BuildLikelihoodGrid would lay over a cloud (its origin and extent in cells), so that
// a grid of part of that cloud can be drawn on the same cells: the same values where the part's
// points are, the same cell boundaries (a grid's phase moves its matches by up to a cell).
struct GridFrame {
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();
  std::int64_t width = 0;
  std::int64_t height = 0;
};
GridFrame GridFrameOf(const PointCloud& points, double resolution, double sigma);

// The field of `points` (a part of the cloud `frame` was laid over) on `frame`'s lattice, stored
// only where it is not zero (x0, y0 > 0). An empty grid when that takes more than `max_cells`.
LikelihoodGrid BuildLikelihoodGrid(const PointCloud& points, double resolution, double sigma,
                                   const GridFrame& frame,
                                   std::int64_t max_cells = kMaxSearchGridCells);

// Max-pooled copies of a grid for branch and bound: level d holds, at cell (x, y), the largest
// value of the base cells [x, x + 2^d) x [y, y + 2^d); cells left of and below the grid are
// included (2^depth - 1 of them) so that every candidate window has a cell.
class SearchPyramid {
 public:
  SearchPyramid(LikelihoodGrid grid, int depth);
  int depth() const { return static_cast<int>(levels_.size()) - 1; }
  // One level's cells: lattice cell (x, y) is cells[(y + offset_y) * width + x + offset_x] when
  // that is inside [0, width) x [0, height), else 0. Every level has the same offsets and size.
  struct LevelView {
    const std::uint8_t* cells = nullptr;
    int offset_x = 0;
    int offset_y = 0;
    int width = 0;
    int height = 0;
  };
  LevelView level(int d) const {
    const Level& l = levels_[d];
    return LevelView{l.cells.data(), l.offset_x, l.offset_y, l.width, l.height};
  }
  std::uint8_t At(int level, int x, int y) const {
    const LevelView l = this->level(level);
    x += l.offset_x;
    y += l.offset_y;
    return x < 0 || y < 0 || x >= l.width || y >= l.height
               ? 0
               : l.cells[static_cast<size_t>(y) * l.width + x];
  }
  const LikelihoodGrid& base() const { return base_; }
  // Memory held (cells of every level), for caches.
  size_t bytes() const;

 private:
  struct Level {
    int offset_x = 0;  // lattice -> storage index
    int offset_y = 0;
    int width = 0;
    int height = 0;
    std::vector<std::uint8_t> cells;
  };
  LikelihoodGrid base_;
  std::vector<Level> levels_;
};

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_MAPPING_LIKELIHOOD_GRID_H_
