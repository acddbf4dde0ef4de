#include "server/laser_slam/mapping/likelihood_grid.h"

#include <algorithm>
#include <cmath>

namespace waymark::laser_slam {

double LikelihoodGrid::Interpolate(double px, double py) const {
  const double gx = (px - origin.x()) / resolution - 0.5;
  const double gy = (py - origin.y()) / resolution - 0.5;
  const int x0 = static_cast<int>(std::floor(gx)), y0 = static_cast<int>(std::floor(gy));
  const double fx = gx - x0, fy = gy - y0;
  const double v = (1 - fx) * (1 - fy) * At(x0, y0) + fx * (1 - fy) * At(x0 + 1, y0) +
                   (1 - fx) * fy * At(x0, y0 + 1) + fx * fy * At(x0 + 1, y0 + 1);
  return v / 255.0;
}

LikelihoodGrid BuildLikelihoodGrid(const PointCloud& points, double resolution, double sigma,
                                   std::int64_t max_cells) {
  LikelihoodGrid grid;
  grid.resolution = resolution;
  if (points.empty()) return grid;
  Eigen::Vector2f lo = points.front(), hi = points.front();
  for (const Eigen::Vector2f& p : points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const double margin = 3.0 * sigma + resolution;
  // Sizes in double first: a span of 10^7 m in cells overflows an int.
  const double width = std::ceil((double(hi.x()) - lo.x() + 2 * margin) / resolution) + 1;
  const double height = std::ceil((double(hi.y()) - lo.y() + 2 * margin) / resolution) + 1;
  if (!(width * height <= static_cast<double>(max_cells))) return grid;
  grid.origin = lo.cast<double>() - Eigen::Vector2d::Constant(margin);
  grid.width = static_cast<int>(width);
  grid.height = static_cast<int>(height);
  grid.cells.assign(static_cast<size_t>(grid.width) * grid.height, 0);
  // The kernel, as bytes, by squared cell distance from the point's cell centre.
  const int radius = static_cast<int>(std::ceil(3.0 * sigma / resolution));
  std::vector<std::uint8_t> kernel((2 * radius + 1) * (2 * radius + 1));
  for (int dy = -radius; dy <= radius; ++dy) {
    for (int dx = -radius; dx <= radius; ++dx) {
      const double d2 = (dx * dx + dy * dy) * resolution * resolution;
      kernel[(dy + radius) * (2 * radius + 1) + dx + radius] =
          static_cast<std::uint8_t>(std::lround(255.0 * std::exp(-0.5 * d2 / (sigma * sigma))));
    }
  }
  for (const Eigen::Vector2f& p : points) {
    const int cx = static_cast<int>((p.x() - grid.origin.x()) / resolution);
    const int cy = static_cast<int>((p.y() - grid.origin.y()) / resolution);
    for (int dy = -radius; dy <= radius; ++dy) {
      const int y = cy + dy;
      if (y < 0 || y >= grid.height) continue;
      for (int dx = -radius; dx <= radius; ++dx) {
        const int x = cx + dx;
        if (x < 0 || x >= grid.width) continue;
        std::uint8_t& cell = grid.cells[static_cast<size_t>(y) * grid.width + x];
        cell = std::max(cell, kernel[(dy + radius) * (2 * radius + 1) + dx + radius]);
      }
    }
  }
  return grid;
}

SearchPyramid::SearchPyramid(const LikelihoodGrid& grid, int depth) : base_(grid) {
  Level level0;
  level0.width = grid.width;
  level0.height = grid.height;
  level0.cells = grid.cells;
  levels_.push_back(std::move(level0));
  for (int d = 1; d <= depth; ++d) {
    const Level& prev = levels_.back();
    const int half = 1 << (d - 1);
    Level next;
    next.offset = (1 << d) - 1;
    next.width = grid.width + next.offset;
    next.height = grid.height + next.offset;
    next.cells.assign(static_cast<size_t>(next.width) * next.height, 0);
    const auto prev_at = [&](int x, int y) {  // x, y in grid coordinates
      x += prev.offset;
      y += prev.offset;
      return x < 0 || y < 0 || x >= prev.width || y >= prev.height
                 ? std::uint8_t{0}
                 : prev.cells[static_cast<size_t>(y) * prev.width + x];
    };
    for (int y = -next.offset; y < grid.height; ++y) {
      for (int x = -next.offset; x < grid.width; ++x) {
        next.cells[static_cast<size_t>(y + next.offset) * next.width + x + next.offset] =
            std::max(std::max(prev_at(x, y), prev_at(x + half, y)),
                     std::max(prev_at(x, y + half), prev_at(x + half, y + half)));
      }
    }
    levels_.push_back(std::move(next));
  }
}

}  // namespace waymark::laser_slam
