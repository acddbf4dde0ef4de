#include "client/sim/sim_reach.h"

#include <algorithm>
#include <cmath>
#include <queue>
#include <utility>

#include "client/sim/sim_geometry.h"

namespace waymark::adapters {
namespace {

constexpr double kPi = 3.14159265358979323846;

// A wall crossing a line closer to its start than this crosses it at the sample itself: the
// sample's own wall, or one lying on it (the back of a box flush against it, whose other sides
// still block), or a wall given twice.
constexpr double kAtTheSample = 1e-6;

// Node index of a coordinate (nearest node), on either axis.
int Node(double v, double origin, double cell) {
  return static_cast<int>(std::lround((v - origin) / cell));
}

// Nodes closer than `radius` to some wall. Each wall marks only the nodes in its bounding box
// grown by the radius, so this costs the walls' area rather than walls times the grid.
std::vector<char> BlockedNodes(const World& world, const Reach& r, double radius) {
  std::vector<char> blocked(static_cast<size_t>(r.nx) * r.ny, 0);
  for (const Wall& w : world.walls) {
    const int i0 = std::max(0, Node(std::min(w.x1, w.x2) - radius, r.x0, r.cell) - 1);
    const int i1 = std::min(r.nx - 1, Node(std::max(w.x1, w.x2) + radius, r.x0, r.cell) + 1);
    const int j0 = std::max(0, Node(std::min(w.y1, w.y2) - radius, r.y0, r.cell) - 1);
    const int j1 = std::min(r.ny - 1, Node(std::max(w.y1, w.y2) + radius, r.y0, r.cell) + 1);
    for (int j = j0; j <= j1; ++j) {
      for (int i = i0; i <= i1; ++i) {
        char& b = blocked[static_cast<size_t>(j) * r.nx + i];
        if (!b)
          b = geometry::PointSegmentDistance(r.x0 + i * r.cell, r.y0 + j * r.cell, w) < radius;
      }
    }
  }
  return blocked;
}

// Directions as offsets from a wall's normal, those closest to the normal on either side first:
// a sample facing reachable space mostly finds it with the first few, so only the hidden ones
// cost every direction.
std::vector<double> NormalFirstOffsets(int rays) {
  std::vector<double> offsets;
  for (int k = 0; k < rays; ++k) offsets.push_back(-kPi + 2 * kPi * k / rays);
  std::stable_sort(offsets.begin(), offsets.end(), [](double a, double b) {
    return std::min(std::abs(a), kPi - std::abs(a)) < std::min(std::abs(b), kPi - std::abs(b));
  });
  return offsets;
}

}  // namespace

long Reach::Index(double x, double y) const {
  // Rounded by truncation rather than Node()'s lround: VisibleWalls spends most of its time here,
  // and a libm call per step doubled it.
  const double gx = (x - x0) / cell + 0.5, gy = (y - y0) / cell + 0.5;
  if (!(gx >= 0 && gy >= 0 && gx < nx && gy < ny)) return -1;
  return static_cast<long>(gy) * nx + static_cast<long>(gx);
}

bool Reach::At(double x, double y) const {
  const long index = Index(x, y);
  return index >= 0 && reached[index] != 0;
}

Reach ReachableSpace(const World& world, double radius, double cell) {
  double xmin = world.start.x, xmax = xmin, ymin = world.start.y, ymax = ymin;
  for (const Wall& w : world.walls) {
    xmin = std::min({xmin, w.x1, w.x2});
    xmax = std::max({xmax, w.x1, w.x2});
    ymin = std::min({ymin, w.y1, w.y2});
    ymax = std::max({ymax, w.y1, w.y2});
  }
  Reach r;
  r.cell = cell;
  r.x0 = std::floor(xmin) - 1;
  r.y0 = std::floor(ymin) - 1;
  r.nx = static_cast<int>(std::ceil((xmax + 1 - r.x0) / cell)) + 1;
  r.ny = static_cast<int>(std::ceil((ymax + 1 - r.y0) / cell)) + 1;
  r.reached.assign(static_cast<size_t>(r.nx) * r.ny, 0);
  const std::vector<char> blocked = BlockedNodes(world, r, radius);
  const int si = Node(world.start.x, r.x0, cell), sj = Node(world.start.y, r.y0, cell);
  if (blocked[static_cast<size_t>(sj) * r.nx + si]) return r;
  std::queue<std::pair<int, int>> queue;
  r.reached[static_cast<size_t>(sj) * r.nx + si] = 1;
  queue.push({si, sj});
  while (!queue.empty()) {
    const auto [i, j] = queue.front();
    queue.pop();
    if (i == 0 || j == 0 || i == r.nx - 1 || j == r.ny - 1) {
      r.leaked = true;
      continue;
    }
    for (const auto& [di, dj] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
      const size_t next = static_cast<size_t>(j + dj) * r.nx + (i + di);
      if (r.reached[next] || blocked[next]) continue;
      r.reached[next] = 1;
      queue.push({i + di, j + dj});
    }
  }
  return r;
}

std::vector<WallSample> SampleWalls(const std::vector<Wall>& walls, double step) {
  std::vector<WallSample> samples;
  for (size_t k = 0; k < walls.size(); ++k) {
    const Wall& w = walls[k];
    const double length = std::hypot(w.x2 - w.x1, w.y2 - w.y1);
    if (!(length > 0)) continue;
    const int pieces = std::max(1, static_cast<int>(std::ceil(length / step)));
    for (int p = 0; p < pieces; ++p) {
      const double t = (p + 0.5) / pieces;
      samples.push_back({static_cast<int>(k), w.x1 + t * (w.x2 - w.x1), w.y1 + t * (w.y2 - w.y1),
                         length / pieces});
    }
  }
  return samples;
}

double SampleLength(const std::vector<WallSample>& samples) {
  double total = 0;
  for (const WallSample& s : samples) total += s.length;
  return total;
}

std::vector<WallSample> VisibleWalls(const World& world, const VisibilityOptions& options) {
  const Reach reach = ReachableSpace(world, options.radius, options.cell);
  const std::vector<double> offsets = NormalFirstOffsets(std::max(1, options.rays));
  // Half a cell per step along a line, so it passes no node's cell unseen.
  const double step = options.cell / 2;
  const int steps = static_cast<int>(options.max_range / step);
  std::vector<WallSample> visible;
  std::vector<const Wall*> near;  // the walls that can block a line from the sample
  for (const WallSample& s : SampleWalls(world.walls, options.sample_step)) {
    near.clear();
    for (const Wall& w : world.walls) {
      if (geometry::PointSegmentDistance(s.x, s.y, w) <= options.max_range) near.push_back(&w);
    }
    const Wall& own = world.walls[s.wall];
    const double normal = std::atan2(-(own.x2 - own.x1), own.y2 - own.y1);
    for (const double offset : offsets) {
      const double dx = std::cos(normal + offset), dy = std::sin(normal + offset);
      // The first point of the line in a reached node's cell (it stands for the node: the robot
      // fits there too, within half a cell).
      double reached_at = -1;
      for (int k = 1; k <= steps; ++k) {
        const double t = k * step;
        const long index = reach.Index(s.x + t * dx, s.y + t * dy);
        if (index < 0) break;  // nothing is reached outside the grid
        if (reach.reached[index]) {
          reached_at = t;
          break;
        }
      }
      if (reached_at < 0) continue;
      const bool blocked = std::any_of(near.begin(), near.end(), [&](const Wall* w) {
        const double t = geometry::RaySegmentHit(s.x, s.y, dx, dy, *w);
        return t > kAtTheSample && t < reached_at;
      });
      if (!blocked) {
        visible.push_back(s);
        break;
      }
    }
  }
  return visible;
}

}  // namespace waymark::adapters
