#include "server/laser_slam/exploration/frontiers.h"

#include <cmath>
#include <vector>

namespace waymark::laser_slam {
namespace {

constexpr int kDx4[] = {1, -1, 0, 0};
constexpr int kDy4[] = {0, 0, 1, -1};

bool Touches(const ExplorationGrid& grid, int x, int y, GridCell kind) {
  for (int k = 0; k < 4; ++k) {
    const int nx = x + kDx4[k], ny = y + kDy4[k];
    if (grid.Inside(nx, ny) && grid.At(nx, ny) == kind) return true;
  }
  return false;
}

// An unknown cell next to an occupied one (8-neighbourhood) is a gap in a mapped wall, not
// open space: a wall seen at a grazing angle is hit in some cells and crossed by rays in others.
bool OpenUnknown(const ExplorationGrid& grid, int x, int y) {
  if (!grid.Inside(x, y) || grid.At(x, y) != GridCell::kUnknown) return false;
  for (int dy = -1; dy <= 1; ++dy) {
    for (int dx = -1; dx <= 1; ++dx) {
      if (grid.Inside(x + dx, y + dy) && grid.At(x + dx, y + dy) == GridCell::kOccupied) {
        return false;
      }
    }
  }
  return true;
}

bool TouchesOpenUnknown(const ExplorationGrid& grid, int x, int y) {
  for (int k = 0; k < 4; ++k) {
    if (OpenUnknown(grid, x + kDx4[k], y + kDy4[k])) return true;
  }
  return false;
}

}  // namespace

Frontiers FindFrontiers(const ExplorationGrid& grid, int min_cells) {
  Frontiers out;
  const int w = grid.width(), h = grid.height();
  std::vector<char> frontier(static_cast<size_t>(w) * h, 0);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      const GridCell cell = grid.At(x, y);
      if (cell == GridCell::kFree && TouchesOpenUnknown(grid, x, y)) {
        frontier[grid.Index(x, y)] = 1;
        ++out.open_cells;
      } else if (cell == GridCell::kOccupied && Touches(grid, x, y, GridCell::kFree)) {
        ++out.closed_cells;
      }
    }
  }
  out.regions = ConnectedRegions(grid, frontier, min_cells);
  out.mask = std::move(frontier);
  return out;
}


bool MaskedNear(const ExplorationGrid& grid, const std::vector<char>& mask,
                const Eigen::Vector2d& point, double radius) {
  if (mask.empty()) return false;
  const Eigen::Vector2i c = grid.CellOf(point);
  const int r = static_cast<int>(std::ceil(radius / grid.resolution()));
  for (int dy = -r; dy <= r; ++dy) {
    for (int dx = -r; dx <= r; ++dx) {
      const int x = c.x() + dx, y = c.y() + dy;
      if (grid.Inside(x, y) && mask[grid.Index(x, y)] &&
          (grid.Centre(x, y) - point).norm() <= radius) {
        return true;
      }
    }
  }
  return false;
}

std::vector<GridRegion> ConnectedRegions(const ExplorationGrid& grid, std::vector<char> mask,
                                         int min_cells) {
  std::vector<GridRegion> regions;
  const int w = grid.width(), h = grid.height();
  std::vector<int> stack;
  for (int start = 0; start < w * h; ++start) {
    if (mask[start] != 1) continue;
    GridRegion region;
    mask[start] = 2;
    stack.push_back(start);
    while (!stack.empty()) {
      const int i = stack.back();
      stack.pop_back();
      region.cells.push_back(i);
      const int x = i % w, y = i / w;
      region.centroid += grid.Centre(x, y);
      for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
          if (!grid.Inside(x + dx, y + dy)) continue;
          const int j = grid.Index(x + dx, y + dy);
          if (mask[j] == 1) {
            mask[j] = 2;
            stack.push_back(j);
          }
        }
      }
    }
    if (static_cast<int>(region.cells.size()) < min_cells) continue;
    region.centroid /= static_cast<double>(region.cells.size());
    region.length = region.cells.size() * grid.resolution();
    regions.push_back(std::move(region));
  }
  return regions;
}

}  // namespace waymark::laser_slam
