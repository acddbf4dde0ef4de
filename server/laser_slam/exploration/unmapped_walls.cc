#include "server/laser_slam/exploration/unmapped_walls.h"

#include <cmath>

#include "server/laser_slam/geometry.h"

namespace waymark::laser_slam {
namespace {

bool NextToFree(const ExplorationGrid& grid, int x, int y) {
  for (int dy = -1; dy <= 1; ++dy) {
    for (int dx = -1; dx <= 1; ++dx) {
      if (grid.Inside(x + dx, y + dy) && grid.At(x + dx, y + dy) == GridCell::kFree) return true;
    }
  }
  return false;
}

}  // namespace

UnmappedWalls FindUnmappedWalls(const ExplorationGrid& grid, const std::vector<MapSegment>& segments,
                                double explained, int min_cells) {
  UnmappedWalls out;
  const int w = grid.width(), h = grid.height();
  if (w == 0) return out;
  // The cells each segment explains: every cell whose centre is within `explained` of it.
  std::vector<char> mapped(static_cast<size_t>(w) * h, 0);
  const double r = grid.resolution();
  const int reach = static_cast<int>(std::ceil(explained / r)) + 1;
  for (const MapSegment& s : segments) {
    const Pose2 a = Compose(s.frame, Pose2{s.left, 0.0, 0.0});
    const Pose2 b = Compose(s.frame, Pose2{s.right, 0.0, 0.0});
    const Eigen::Vector2d pa(a.x, a.y), pb(b.x, b.y);
    const int steps = std::max(1, static_cast<int>(std::ceil((pb - pa).norm() / r)));
    for (int k = 0; k <= steps; ++k) {
      const Eigen::Vector2i c = grid.CellOf(pa + (pb - pa) * (static_cast<double>(k) / steps));
      for (int dy = -reach; dy <= reach; ++dy) {
        for (int dx = -reach; dx <= reach; ++dx) {
          const int x = c.x() + dx, y = c.y() + dy;
          if (!grid.Inside(x, y) || mapped[grid.Index(x, y)]) continue;
          if (PointSegmentDistance(grid.Centre(x, y), pa, pb) <= explained) {
            mapped[grid.Index(x, y)] = 1;
          }
        }
      }
    }
  }
  std::vector<char> unmapped(static_cast<size_t>(w) * h, 0);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      if (grid.At(x, y) != GridCell::kOccupied || !NextToFree(grid, x, y)) continue;
      if (mapped[grid.Index(x, y)]) {
        ++out.mapped_cells;
      } else {
        unmapped[grid.Index(x, y)] = 1;
        ++out.unmapped_cells;
      }
    }
  }
  out.regions = ConnectedRegions(grid, unmapped, min_cells);
  out.mask = std::move(unmapped);
  return out;
}

}  // namespace waymark::laser_slam
