#include "server/laser_slam/mapping/likelihood_grid.h"

#include <algorithm>
#include <cmath>
#include <utility>

namespace waymark::laser_slam {

namespace {

// The kernel, as bytes, by cell offset from the point's cell (row-major, 2 radius + 1 wide).
std::vector<std::uint8_t> Kernel(double resolution, double sigma, int radius) {
  std::vector<std::uint8_t> kernel((2 * radius + 1) * (2 * radius + 1));
  for (int dy = -radius; dy <= radius; ++dy) {
    for (int dx = -radius; dx <= radius; ++dx) {
      const double d2 = (dx * dx + dy * dy) * resolution * resolution;
      kernel[(dy + radius) * (2 * radius + 1) + dx + radius] =
          static_cast<std::uint8_t>(std::lround(255.0 * std::exp(-0.5 * d2 / (sigma * sigma))));
    }
  }
  return kernel;
}

int KernelRadius(double resolution, double sigma) {
  return static_cast<int>(std::ceil(3.0 * sigma / resolution));
}

// The point's cell on the lattice of `origin`.
std::int64_t CellOf(float p, double origin, double resolution) {
  return static_cast<std::int64_t>((p - origin) / resolution);
}

// Draws every point's kernel into the grid's stored cells (origin, x0, y0, width, height set).
void Stamp(const PointCloud& points, double sigma, LikelihoodGrid& grid) {
  const double resolution = grid.resolution;
  grid.cells.assign(static_cast<size_t>(grid.width) * grid.height, 0);
  const int radius = KernelRadius(resolution, sigma);
  const std::vector<std::uint8_t> kernel = Kernel(resolution, sigma, radius);
  const int span = 2 * radius + 1;
  for (const Eigen::Vector2f& p : points) {
    const int cx = static_cast<int>(CellOf(p.x(), grid.origin.x(), resolution) - grid.x0);
    const int cy = static_cast<int>(CellOf(p.y(), grid.origin.y(), resolution) - grid.y0);
    const int x_from = std::max(-radius, -cx), x_to = std::min(radius, grid.width - 1 - cx);
    for (int dy = -radius; dy <= radius; ++dy) {
      const int y = cy + dy;
      if (y < 0 || y >= grid.height) continue;
      std::uint8_t* row = grid.cells.data() + static_cast<size_t>(y) * grid.width;
      const std::uint8_t* k = kernel.data() + (dy + radius) * span + radius;
      for (int dx = x_from; dx <= x_to; ++dx) row[cx + dx] = std::max(row[cx + dx], k[dx]);
    }
  }
}

}  // namespace

GridFrame GridFrameOf(const PointCloud& points, double resolution, double sigma) {
  GridFrame frame;
  if (points.empty()) return frame;
  Eigen::Vector2f lo = points.front(), hi = points.front();
  for (const Eigen::Vector2f& p : points) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const double margin = 3.0 * sigma + resolution;
  frame.origin = lo.cast<double>() - Eigen::Vector2d::Constant(margin);
  // Sizes in double first: a span of 10^7 m in cells overflows an int.
  frame.width = static_cast<std::int64_t>(
      std::ceil((double(hi.x()) - lo.x() + 2 * margin) / resolution) + 1);
  frame.height = static_cast<std::int64_t>(
      std::ceil((double(hi.y()) - lo.y() + 2 * margin) / resolution) + 1);
  return frame;
}

LikelihoodGrid BuildLikelihoodGrid(const PointCloud& points, double resolution, double sigma,
                                   std::int64_t max_cells) {
  LikelihoodGrid grid;
  grid.resolution = resolution;
  if (points.empty()) return grid;
  const GridFrame frame = GridFrameOf(points, resolution, sigma);
  if (!(static_cast<double>(frame.width) * static_cast<double>(frame.height) <=
        static_cast<double>(max_cells))) {
    return grid;
  }
  grid.origin = frame.origin;
  grid.width = static_cast<int>(frame.width);
  grid.height = static_cast<int>(frame.height);
  Stamp(points, sigma, grid);
  return grid;
}

LikelihoodGrid BuildLikelihoodGrid(const PointCloud& points, double resolution, double sigma,
                                   const GridFrame& frame, std::int64_t max_cells) {
  LikelihoodGrid grid;
  grid.resolution = resolution;
  if (points.empty()) return grid;
  const int radius = KernelRadius(resolution, sigma);
  std::int64_t lo_x = frame.width, lo_y = frame.height, hi_x = -1, hi_y = -1;
  for (const Eigen::Vector2f& p : points) {
    const std::int64_t cx = CellOf(p.x(), frame.origin.x(), resolution);
    const std::int64_t cy = CellOf(p.y(), frame.origin.y(), resolution);
    lo_x = std::min(lo_x, cx);
    lo_y = std::min(lo_y, cy);
    hi_x = std::max(hi_x, cx);
    hi_y = std::max(hi_y, cy);
  }
  // The cells the kernels reach, within the frame (its cells beyond were never drawn).
  lo_x = std::max<std::int64_t>(0, lo_x - radius);
  lo_y = std::max<std::int64_t>(0, lo_y - radius);
  hi_x = std::min<std::int64_t>(frame.width - 1, hi_x + radius);
  hi_y = std::min<std::int64_t>(frame.height - 1, hi_y + radius);
  constexpr std::int64_t kMaxIndex = 1 << 30;
  if (hi_x < lo_x || hi_y < lo_y || hi_x >= kMaxIndex || hi_y >= kMaxIndex ||
      (hi_x - lo_x + 1) * (hi_y - lo_y + 1) > max_cells) {
    return grid;
  }
  grid.origin = frame.origin;
  grid.x0 = static_cast<int>(lo_x);
  grid.y0 = static_cast<int>(lo_y);
  grid.width = static_cast<int>(hi_x - lo_x + 1);
  grid.height = static_cast<int>(hi_y - lo_y + 1);
  Stamp(points, sigma, grid);
  return grid;
}

SearchPyramid::SearchPyramid(LikelihoodGrid grid, int depth) : base_(std::move(grid)) {
  // Every level on the same storage (offset and row stride), so that one index per point serves
  // them all: the base grid padded by 2^depth - 1 cells below and left, where level d's cells
  // begin (2^d - 1 before the base grid's first cell; the rest of the pad stays 0).
  const int pad = (1 << depth) - 1;
  Level level;
  level.offset_x = pad - base_.x0;
  level.offset_y = pad - base_.y0;
  level.width = base_.width + pad;
  level.height = base_.height + pad;
  level.cells.assign(static_cast<size_t>(level.width) * level.height, 0);
  for (int y = 0; y < base_.height; ++y) {
    std::copy_n(base_.cells.data() + static_cast<size_t>(y) * base_.width, base_.width,
                level.cells.data() + static_cast<size_t>(y + pad) * level.width + pad);
  }
  levels_.push_back(std::move(level));
  // Level d at lattice x is the larger of level d - 1 at x and at x + 2^(d-1) (0 beyond the
  // storage), along rows, then along columns.
  std::vector<std::uint8_t> rows;
  for (int d = 1; d <= depth; ++d) {
    const Level& prev = levels_.back();
    const int half = 1 << (d - 1);
    const int width = prev.width, height = prev.height;
    rows.resize(prev.cells.size());
    for (int y = 0; y < height; ++y) {
      const std::uint8_t* in = prev.cells.data() + static_cast<size_t>(y) * width;
      std::uint8_t* out = rows.data() + static_cast<size_t>(y) * width;
      const int split = std::max(0, width - half);
      for (int i = 0; i < split; ++i) out[i] = std::max(in[i], in[i + half]);
      for (int i = split; i < width; ++i) out[i] = in[i];
    }
    Level next;
    next.offset_x = prev.offset_x;
    next.offset_y = prev.offset_y;
    next.width = width;
    next.height = height;
    next.cells.resize(prev.cells.size());
    for (int y = 0; y < height; ++y) {
      const std::uint8_t* in = rows.data() + static_cast<size_t>(y) * width;
      std::uint8_t* out = next.cells.data() + static_cast<size_t>(y) * width;
      if (y + half < height) {
        const std::uint8_t* above = in + static_cast<size_t>(half) * width;
        for (int i = 0; i < width; ++i) out[i] = std::max(in[i], above[i]);
      } else {
        std::copy_n(in, width, out);
      }
    }
    levels_.push_back(std::move(next));
  }
}

size_t SearchPyramid::bytes() const {
  size_t total = base_.cells.size();
  for (const Level& l : levels_) total += l.cells.size();
  return total;
}

}  // namespace waymark::laser_slam
