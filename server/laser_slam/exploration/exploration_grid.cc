#include "server/laser_slam/exploration/exploration_grid.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "server/laser_slam/geometry.h"

namespace waymark::laser_slam {
namespace {

constexpr std::int8_t kUnknownValue = -128;
// Log odds in tenths: a return counts more than a crossing beam, so that one beam grazing a wall
// does not erase it; clamped so that a cell can change its mind after a few scans.
constexpr int kHit = 9;
constexpr int kMiss = -4;
constexpr int kClamp = 40;
// The grid grows by at least this much (m) on a side, so a robot driving on does not
// reallocate it at every scan; every decision passes over the whole grid, so the margin costs
// time too (8 m made a 40 x 30 m floor's grid twice its known area).
constexpr double kGrowth = 3.0;

}  // namespace

ExplorationGrid::ExplorationGrid(double resolution) : resolution_(resolution) {}

GridCell ExplorationGrid::At(int x, int y) const {
  const std::int8_t v = cells_[Index(x, y)];
  if (v == kUnknownValue) return GridCell::kUnknown;
  return v > 0 ? GridCell::kOccupied : GridCell::kFree;
}

Eigen::Vector2i ExplorationGrid::CellOf(const Eigen::Vector2d& point) const {
  const Eigen::Vector2d c = (point - origin_) / resolution_;
  return Eigen::Vector2i(static_cast<int>(std::floor(c.x())), static_cast<int>(std::floor(c.y())));
}

Eigen::Vector2d ExplorationGrid::Centre(int x, int y) const {
  return origin_ + resolution_ * Eigen::Vector2d(x + 0.5, y + 0.5);
}

void ExplorationGrid::Cover(const Eigen::Vector2d& lo, const Eigen::Vector2d& hi) {
  const Eigen::Vector2d top = origin_ + resolution_ * Eigen::Vector2d(width_, height_);
  if (width_ > 0 && lo.x() >= origin_.x() && lo.y() >= origin_.y() && hi.x() < top.x() &&
      hi.y() < top.y()) {
    return;
  }
  // Grow only the sides that need it, by a whole block, on the old cells' lattice (nothing is
  // resampled).
  const bool have = width_ > 0;
  const Eigen::Vector2d anchor = have ? origin_ : Eigen::Vector2d::Zero();
  auto lower = [&](double want, double old, double o) {
    if (have && want >= old) return old;
    return o + resolution_ * std::floor((want - kGrowth - o) / resolution_);
  };
  auto upper = [&](double want, double old) {
    return have && want < old ? old : want + kGrowth;
  };
  const Eigen::Vector2d origin(lower(lo.x(), origin_.x(), anchor.x()),
                               lower(lo.y(), origin_.y(), anchor.y()));
  const double top_x = upper(hi.x(), top.x()), top_y = upper(hi.y(), top.y());
  const int width = static_cast<int>(std::ceil((top_x - origin.x()) / resolution_ - 1e-9));
  const int height = static_cast<int>(std::ceil((top_y - origin.y()) / resolution_ - 1e-9));
  std::vector<std::int8_t> cells(static_cast<size_t>(width) * height, kUnknownValue);
  if (width_ > 0) {
    const int dx = static_cast<int>(std::lround((origin_.x() - origin.x()) / resolution_));
    const int dy = static_cast<int>(std::lround((origin_.y() - origin.y()) / resolution_));
    for (int y = 0; y < height_; ++y) {
      std::copy_n(cells_.begin() + static_cast<size_t>(y) * width_, width_,
                  cells.begin() + static_cast<size_t>(y + dy) * width + dx);
    }
  }
  origin_ = origin;
  width_ = width;
  height_ = height;
  cells_ = std::move(cells);
}

void ExplorationGrid::Add(int x, int y, int delta) {
  if (!Inside(x, y)) return;
  std::int8_t& v = cells_[Index(x, y)];
  const int base = v == kUnknownValue ? 0 : v;
  v = static_cast<std::int8_t>(std::clamp(base + delta, -kClamp, kClamp));
}

// Cells from `from` to `to` (Amanatides-Woo traversal): free up to the last, which is occupied
// when `hit`.
void ExplorationGrid::Ray(const Eigen::Vector2d& from, const Eigen::Vector2d& to, bool hit) {
  Eigen::Vector2i cell = CellOf(from);
  const Eigen::Vector2i end = CellOf(to);
  const Eigen::Vector2d d = to - from;
  const int step_x = d.x() > 0 ? 1 : -1, step_y = d.y() > 0 ? 1 : -1;
  const Eigen::Vector2d start_in_cells = (from - origin_) / resolution_;
  auto first_crossing = [](double p, double dp, int step) -> double {
    if (dp == 0) return std::numeric_limits<double>::infinity();
    const double boundary = step > 0 ? std::floor(p) + 1 : std::floor(p);
    return (boundary - p) / dp;
  };
  const Eigen::Vector2d d_cells = d / resolution_;
  double t_x = first_crossing(start_in_cells.x(), d_cells.x(), step_x);
  double t_y = first_crossing(start_in_cells.y(), d_cells.y(), step_y);
  const double dt_x = d_cells.x() != 0 ? std::abs(1.0 / d_cells.x()) : std::numeric_limits<double>::infinity();
  const double dt_y = d_cells.y() != 0 ? std::abs(1.0 / d_cells.y()) : std::numeric_limits<double>::infinity();
  const int max_steps = std::abs(end.x() - cell.x()) + std::abs(end.y() - cell.y());
  for (int i = 0; i < max_steps && cell != end; ++i) {
    Add(cell.x(), cell.y(), kMiss);
    if (t_x < t_y) {
      cell.x() += step_x;
      t_x += dt_x;
    } else {
      cell.y() += step_y;
      t_y += dt_y;
    }
  }
  Add(end.x(), end.y(), hit ? kHit : kMiss);
}

void ExplorationGrid::Integrate(const Pose2& robot, const Pose2& laser_pose, const LaserScan& scan,
                                double max_range, double free_range, double body_radius) {
  const Pose2 laser = Compose(robot, laser_pose);
  const Eigen::Vector2d from(laser.x, laser.y);
  const double reach = std::max({max_range, free_range, body_radius}) + resolution_;
  const Eigen::Vector2d centre(robot.x, robot.y);
  Cover(from.cwiseMin(centre) - Eigen::Vector2d::Constant(reach),
        from.cwiseMax(centre) + Eigen::Vector2d::Constant(reach));
  const int beams = std::min<int>(scan.geometry.beam_count, static_cast<int>(scan.ranges.size()));
  for (int i = 0; i < beams; ++i) {
    const double r = scan.ranges[i];
    const bool is_return = IsReturn(r, scan.geometry);
    // A non-finite or non-positive reading says nothing; a no-return says "free up to range".
    if (!is_return && !(scan.geometry.no_return_range > 0.0 && r >= scan.geometry.no_return_range)) {
      continue;
    }
    const bool hit = is_return && r < max_range;
    const double length = hit ? r : std::min(is_return ? r : free_range, free_range);
    const double bearing = laser.theta + scan.geometry.angle_min + i * scan.geometry.angle_increment;
    const Eigen::Vector2d to = from + length * Eigen::Vector2d(std::cos(bearing), std::sin(bearing));
    Ray(from, to, hit);
  }
  const int r = static_cast<int>(std::ceil(body_radius / resolution_));
  const Eigen::Vector2i c = CellOf(centre);
  for (int dy = -r; dy <= r; ++dy) {
    for (int dx = -r; dx <= r; ++dx) {
      if ((Centre(c.x() + dx, c.y() + dy) - centre).norm() > body_radius) continue;
      if (Inside(c.x() + dx, c.y() + dy)) cells_[Index(c.x() + dx, c.y() + dy)] = -kClamp;
    }
  }
}

void ExplorationGrid::Set(const Eigen::Vector2d& point, GridCell cell) {
  Cover(point, point);
  const Eigen::Vector2i c = CellOf(point);
  cells_[Index(c.x(), c.y())] = cell == GridCell::kUnknown    ? kUnknownValue
                                : cell == GridCell::kOccupied ? kClamp
                                                              : -kClamp;
}

void ExplorationGrid::FillUnknownFrom(const ExplorationGrid& other, const Pose2& other_to_this) {
  if (other.empty()) return;
  const Eigen::Vector2d top = other.origin_ + other.resolution_ * Eigen::Vector2d(other.width_,
                                                                                 other.height_);
  Eigen::Vector2d lo = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector2d hi = -lo;
  for (const Eigen::Vector2d& corner :
       {other.origin_, top, Eigen::Vector2d(other.origin_.x(), top.y()),
        Eigen::Vector2d(top.x(), other.origin_.y())}) {
    const Eigen::Vector2d p = MoveBy(other_to_this, corner);
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  Cover(lo, hi);
  const Pose2 this_to_other = Invert(other_to_this);
  const Eigen::Vector2i a = CellOf(lo).cwiseMax(Eigen::Vector2i::Zero());
  const Eigen::Vector2i b = CellOf(hi).cwiseMin(Eigen::Vector2i(width_ - 1, height_ - 1));
  for (int y = a.y(); y <= b.y(); ++y) {
    for (int x = a.x(); x <= b.x(); ++x) {
      std::int8_t& v = cells_[Index(x, y)];
      if (v != kUnknownValue) continue;
      const Eigen::Vector2d c = Centre(x, y);
      const Eigen::Vector2i o = other.CellOf(MoveBy(this_to_other, c));
      if (other.Inside(o.x(), o.y())) v = other.cells_[other.Index(o.x(), o.y())];
    }
  }
}

void ExplorationGrid::FreeOccupiedDisc(const Eigen::Vector2d& centre, double radius) {
  if (empty()) return;
  const int r = static_cast<int>(std::ceil(radius / resolution_));
  const Eigen::Vector2i c = CellOf(centre);
  for (int dy = -r; dy <= r; ++dy) {
    for (int dx = -r; dx <= r; ++dx) {
      const int x = c.x() + dx, y = c.y() + dy;
      if (!Inside(x, y) || (Centre(x, y) - centre).norm() > radius) continue;
      std::int8_t& v = cells_[Index(x, y)];
      if (v != kUnknownValue && v > 0) v = -kClamp;
    }
  }
}

double ExplorationGrid::KnownArea() const {
  const auto known = std::count_if(cells_.begin(), cells_.end(),
                                   [](std::int8_t v) { return v != kUnknownValue; });
  return known * resolution_ * resolution_;
}

}  // namespace waymark::laser_slam
