#include "server/laser_slam/exploration/grid_paths.h"

#include <algorithm>
#include <cmath>
#include <queue>

namespace waymark::laser_slam {

std::vector<float> ObstacleDistance(const ExplorationGrid& grid, float cap) {
  const int w = grid.width(), h = grid.height();
  const float r = static_cast<float>(grid.resolution());
  const float diagonal = r * static_cast<float>(M_SQRT2);
  std::vector<float> d(static_cast<size_t>(w) * h, cap);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) {
      if (grid.At(x, y) == GridCell::kOccupied) d[grid.Index(x, y)] = 0.0f;
    }
  }
  auto relax = [&](int x, int y, int nx, int ny, float step) {
    if (nx < 0 || ny < 0 || nx >= w || ny >= h) return;
    float& here = d[static_cast<size_t>(y) * w + x];
    here = std::min(here, d[static_cast<size_t>(ny) * w + nx] + step);
  };
  for (int y = 0; y < h; ++y) {  // forward pass: neighbours already visited
    for (int x = 0; x < w; ++x) {
      relax(x, y, x - 1, y, r);
      relax(x, y, x, y - 1, r);
      relax(x, y, x - 1, y - 1, diagonal);
      relax(x, y, x + 1, y - 1, diagonal);
    }
  }
  for (int y = h - 1; y >= 0; --y) {  // backward pass
    for (int x = w - 1; x >= 0; --x) {
      relax(x, y, x + 1, y, r);
      relax(x, y, x, y + 1, r);
      relax(x, y, x + 1, y + 1, diagonal);
      relax(x, y, x - 1, y + 1, diagonal);
    }
  }
  return d;
}

CostField::CostField(const ExplorationGrid& grid, const std::vector<float>& distance,
                     const Eigen::Vector2d& start, const PathOptions& options)
    : grid_(grid), distance_(distance), options_(options) {
  const Eigen::Vector2i e = grid.CellOf(options.escape_centre);
  escape_floor_ = grid.Inside(e.x(), e.y())
                      ? distance[grid.Index(e.x(), e.y())] - 0.5f * static_cast<float>(grid.resolution())
                      : 0.0f;
  const size_t n = static_cast<size_t>(grid.width()) * grid.height();
  cost_.assign(n, kUnreached);
  length_.assign(n, kUnreached);
  parent_.assign(n, -1);
  const Eigen::Vector2i s = grid.CellOf(start);
  if (!grid.Inside(s.x(), s.y())) return;
  using Entry = std::pair<float, int>;
  std::priority_queue<Entry, std::vector<Entry>, std::greater<Entry>> open;
  const int first = grid.Index(s.x(), s.y());
  cost_[first] = 0.0f;
  length_[first] = 0.0f;
  open.push({0.0f, first});
  const double r = grid.resolution();
  const double span = std::max(options.comfort_distance - options.required_distance, 1e-6);
  const Eigen::Vector2i stop_cell = grid.CellOf(options.stop_near);
  const int stop_index = options.stop_margin > 0.0 && grid.Inside(stop_cell.x(), stop_cell.y())
                             ? grid.Index(stop_cell.x(), stop_cell.y())
                             : -1;
  while (!open.empty()) {
    const auto [c, i] = open.top();
    open.pop();
    if (c > cost_[i]) continue;
    if (stop_index >= 0 && cost_[stop_index] < kUnreached &&
        c > cost_[stop_index] + options.stop_margin) {
      break;
    }
    const int x = i % grid.width(), y = i / grid.width();
    for (int dy = -1; dy <= 1; ++dy) {
      for (int dx = -1; dx <= 1; ++dx) {
        if ((dx == 0 && dy == 0) || !grid.Inside(x + dx, y + dy)) continue;
        const int j = grid.Index(x + dx, y + dy);
        if (!Traversable(j)) continue;
        // A diagonal step must not cut the corner of an untraversable cell.
        if (dx != 0 && dy != 0 &&
            (!Traversable(grid.Index(x + dx, y)) || !Traversable(grid.Index(x, y + dy)))) {
          continue;
        }
        const double step = (dx != 0 && dy != 0) ? r * M_SQRT2 : r;
        const double closeness =
            std::clamp((options.comfort_distance - distance_[j]) / span, 0.0, 1.0);
        const float next = static_cast<float>(c + step * (1.0 + options.wall_penalty * closeness));
        if (next < cost_[j]) {
          cost_[j] = next;
          length_[j] = static_cast<float>(length_[i] + step);
          parent_[j] = i;
          open.push({next, j});
        }
      }
    }
  }
}

bool CostField::Traversable(int index) const {
  const int x = index % grid_.width(), y = index / grid_.width();
  const GridCell cell = grid_.At(x, y);
  if (cell != GridCell::kFree) return false;
  if (distance_[index] >= options_.required_distance) return true;
  return distance_[index] >= escape_floor_ &&
         (grid_.Centre(x, y) - options_.escape_centre).norm() <= options_.escape_radius;
}

int CostField::CellIndex(const Eigen::Vector2d& point) const {
  const Eigen::Vector2i c = grid_.CellOf(point);
  return grid_.Inside(c.x(), c.y()) ? grid_.Index(c.x(), c.y()) : -1;
}

std::vector<Eigen::Vector2d> CostField::PathTo(int index) const {
  std::vector<Eigen::Vector2d> path;
  if (index < 0 || index >= static_cast<int>(cost_.size()) || !Reachable(index)) return path;
  for (int i = index; i >= 0; i = parent_[i]) {
    path.push_back(grid_.CentreOf(i));
  }
  std::reverse(path.begin(), path.end());
  return path;
}

std::vector<Eigen::Vector2d> PlanPath(const ExplorationGrid& grid, const Eigen::Vector2d& from,
                                      const Eigen::Vector2d& to, const PathOptions& options) {
  if (grid.empty()) return {};
  const Eigen::Vector2i goal = grid.CellOf(to);
  if (!grid.Inside(goal.x(), goal.y())) return {};
  const std::vector<float> distance =
      ObstacleDistance(grid, static_cast<float>(options.comfort_distance + 1.0));
  PathOptions escape_at_start = options;
  escape_at_start.escape_centre = from;
  const CostField field(grid, distance, from, escape_at_start);
  return field.PathTo(grid.Index(goal.x(), goal.y()));
}

double PathLength(const std::vector<Eigen::Vector2d>& path) {
  double length = 0.0;
  for (size_t i = 1; i < path.size(); ++i) length += (path[i] - path[i - 1]).norm();
  return length;
}

}  // namespace waymark::laser_slam
