#include "server/laser_slam/mapping/occupancy_grid.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "absl/strings/str_cat.h"

namespace waymark::laser_slam {
namespace {

// Log-odds increments of a hit and a pass-through, and the clamp. A pass counts for less than a
// hit (p(hit) = 0.7, p(pass) = 0.45): rays that graze a wall cross its cells too, and with the
// textbook -0.4 a third fewer wall cells reached "occupied" (Intel: 6954 against 8762), which
// cost a robot localizing on the exported map (44 against 10 poses off by more than 0.5 m).
constexpr float kHit = 0.85f;
constexpr float kMiss = -0.2f;
constexpr float kClamp = 5.0f;

// The box around every node and scan point, map frame.
struct Bounds {
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(1e300);
  Eigen::Vector2d hi = Eigen::Vector2d::Constant(-1e300);
};

Bounds BoundsOf(const std::vector<NodeView>& nodes) {
  Bounds b;
  for (const NodeView& n : nodes) {
    const double c = std::cos(n.global.theta), s = std::sin(n.global.theta);
    const auto extend = [&](double x, double y) {
      b.lo = b.lo.cwiseMin(Eigen::Vector2d(x, y));
      b.hi = b.hi.cwiseMax(Eigen::Vector2d(x, y));
    };
    extend(n.global.x, n.global.y);
    for (const Eigen::Vector2f& q : *n.points) {
      extend(n.global.x + c * q.x() - s * q.y(), n.global.y + s * q.x() + c * q.y());
    }
  }
  return b;
}

// Cells of a grid over `b` at `resolution`, its 2-cell margins and rounding included.
std::int64_t CellsAt(const Bounds& b, double resolution) {
  const Eigen::Vector2d span = (b.hi - b.lo) / resolution + Eigen::Vector2d::Constant(5.0);
  return static_cast<std::int64_t>(std::ceil(span.x())) *
         static_cast<std::int64_t>(std::ceil(span.y()));
}

}  // namespace

double ResolutionThatFits(const std::vector<NodeView>& nodes, double resolution,
                          std::int64_t max_cells) {
  if (nodes.empty()) return resolution;
  const Bounds bounds = BoundsOf(nodes);
  double fits = resolution;
  while (CellsAt(bounds, fits) > max_cells) {
    fits = std::ceil(fits * std::sqrt(double(CellsAt(bounds, fits)) / max_cells) * 1000.0 + 1.0) /
           1000.0;
  }
  return fits;
}

absl::StatusOr<OccupancyGrid> RenderOccupancy(const std::vector<NodeView>& nodes,
                                              double resolution, std::int64_t max_cells) {
  OccupancyGrid grid;
  grid.resolution = resolution;
  if (nodes.empty()) return grid;
  const Bounds bounds = BoundsOf(nodes);
  const double min_x = bounds.lo.x(), max_x = bounds.hi.x();
  const double min_y = bounds.lo.y(), max_y = bounds.hi.y();
  const double margin = 2 * resolution;
  grid.origin = Eigen::Vector2d(std::floor((min_x - margin) / resolution) * resolution,
                                std::floor((min_y - margin) / resolution) * resolution);
  const std::int64_t width =
      static_cast<std::int64_t>(std::ceil((max_x + margin - grid.origin.x()) / resolution));
  const std::int64_t height =
      static_cast<std::int64_t>(std::ceil((max_y + margin - grid.origin.y()) / resolution));
  if (width * height > max_cells) {
    const double fits = resolution * std::sqrt(double(width * height) / max_cells);
    return absl::ResourceExhaustedError(absl::StrCat(
        "the map spans ", max_x - min_x, " x ", max_y - min_y, " m: at ", resolution,
        " m per cell that is ", width * height, " cells (limit ", max_cells,
        "); ask for a resolution of at least ", std::ceil(fits * 1000) / 1000, " m"));
  }
  grid.width = static_cast<int>(width);
  grid.height = static_cast<int>(height);
  std::vector<float> log_odds(static_cast<size_t>(width * height), 0.0f);
  std::vector<std::uint8_t> touched(log_odds.size(), 0);
  const auto cell_of = [&](double x, double y) {
    return Eigen::Vector2i(static_cast<int>(std::floor((x - grid.origin.x()) / resolution)),
                           static_cast<int>(std::floor((y - grid.origin.y()) / resolution)));
  };
  const auto add = [&](const Eigen::Vector2i& c, float delta) {
    if (c.x() < 0 || c.y() < 0 || c.x() >= grid.width || c.y() >= grid.height) return;
    const size_t k = static_cast<size_t>(c.y()) * grid.width + c.x();
    log_odds[k] = std::clamp(log_odds[k] + delta, -kClamp, kClamp);
    touched[k] = 1;
  };
  for (size_t i = 0; i < nodes.size(); ++i) {
    const Eigen::Vector2i from = cell_of(nodes[i].global.x, nodes[i].global.y);
    for (const Eigen::Vector2f& p : TransformPoints(*nodes[i].points, nodes[i].global)) {
      const Eigen::Vector2i to = cell_of(p.x(), p.y());
      ForEachCellBefore(from, to, [&](int x, int y) { add({x, y}, kMiss); });
      add(to, kHit);
    }
  }
  grid.cells.resize(log_odds.size());
  for (size_t k = 0; k < log_odds.size(); ++k) {
    if (!touched[k]) {
      grid.cells[k] = -1;
      continue;
    }
    const double p = 1.0 / (1.0 + std::exp(-double(log_odds[k])));
    grid.cells[k] = static_cast<std::int8_t>(std::lround(100.0 * p));
  }
  return grid;
}

PointCloud OccupiedPoints(const OccupancyGrid& grid, int occupied) {
  PointCloud points;
  for (int y = 0; y < grid.height; ++y) {
    for (int x = 0; x < grid.width; ++x) {
      if (grid.At(x, y) >= occupied) {
        points.emplace_back(static_cast<float>(grid.origin.x() + (x + 0.5) * grid.resolution),
                            static_cast<float>(grid.origin.y() + (y + 0.5) * grid.resolution));
      }
    }
  }
  return points;
}

}  // namespace waymark::laser_slam
