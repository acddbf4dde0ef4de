#include "server/laser_slam/mapping/seen_mask.h"

#include <algorithm>
#include <cmath>
#include <vector>

#include "server/laser_slam/mapping/likelihood_grid.h"

namespace waymark::laser_slam {

bool SeenMask::Seen(double x, double y) const {
  const double gx = (x - origin.x()) / resolution, gy = (y - origin.y()) / resolution;
  if (!(gx >= 0.0 && gy >= 0.0 && gx < width && gy < height)) return false;
  return cells[static_cast<size_t>(gy) * width + static_cast<size_t>(gx)] != 0;
}

SeenMask BuildSeenMask(const std::vector<SeenScan>& scans, double resolution,
                       std::int64_t max_cells) {
  SeenMask mask;
  mask.resolution = resolution;
  // Every beam as its origin and return, in the mask's frame, once.
  struct Beam {
    Eigen::Vector2d from, to;
  };
  std::vector<Beam> beams;
  Eigen::Vector2d lo(1e300, 1e300), hi(-1e300, -1e300);
  for (const SeenScan& s : scans) {
    if (s.points == nullptr) continue;
    const Eigen::Vector2d o(s.pose.x, s.pose.y);
    lo = lo.cwiseMin(o);
    hi = hi.cwiseMax(o);
    const double c = std::cos(s.pose.theta), sn = std::sin(s.pose.theta);
    for (const Eigen::Vector2f& p : *s.points) {
      const Eigen::Vector2d w(s.pose.x + c * p.x() - sn * p.y(), s.pose.y + sn * p.x() + c * p.y());
      lo = lo.cwiseMin(w);
      hi = hi.cwiseMax(w);
      beams.push_back({o, w});
    }
  }
  if (!(lo.x() <= hi.x()) || !std::isfinite(lo.x()) || !std::isfinite(hi.x()) ||
      !std::isfinite(lo.y()) || !std::isfinite(hi.y())) {
    return mask;
  }
  // A margin of two cells: the growth by one, and a point on the far edge of its cell.
  mask.origin = lo - Eigen::Vector2d::Constant(2 * resolution);
  const double w = (hi.x() - lo.x()) / resolution + 5, h = (hi.y() - lo.y()) / resolution + 5;
  if (!(w * h <= static_cast<double>(max_cells))) return mask;
  mask.width = static_cast<int>(w);
  mask.height = static_cast<int>(h);
  std::vector<std::uint8_t> hit(static_cast<size_t>(mask.width) * mask.height, 0);
  for (const Beam& beam : beams) {
    // Half-cell steps along the beam: no cell it crosses is skipped by more than a corner.
    const Eigen::Vector2d along = beam.to - beam.from;
    const int steps = static_cast<int>(std::ceil(along.norm() / (0.5 * resolution)));
    for (int k = 0; k <= steps; ++k) {
      const Eigen::Vector2d at =
          beam.from + (steps > 0 ? static_cast<double>(k) / steps : 1.0) * along;
      const int ix = static_cast<int>((at.x() - mask.origin.x()) / resolution);
      const int iy = static_cast<int>((at.y() - mask.origin.y()) / resolution);
      if (ix >= 0 && iy >= 0 && ix < mask.width && iy < mask.height) {
        hit[static_cast<size_t>(iy) * mask.width + ix] = 1;
      }
    }
  }
  mask.cells.assign(hit.size(), 0);
  for (int y = 0; y < mask.height; ++y) {
    for (int x = 0; x < mask.width; ++x) {
      bool any = false;
      for (int dy = -1; dy <= 1 && !any; ++dy) {
        for (int dx = -1; dx <= 1 && !any; ++dx) {
          const int nx = x + dx, ny = y + dy;
          any = nx >= 0 && ny >= 0 && nx < mask.width && ny < mask.height &&
                hit[static_cast<size_t>(ny) * mask.width + nx] != 0;
        }
      }
      mask.cells[static_cast<size_t>(y) * mask.width + x] = any ? 1 : 0;
    }
  }
  return mask;
}

OverlapScore ScoreWhereSeen(const LikelihoodGrid& grid, const SeenMask& seen,
                            const PointCloud& points, const Pose2& pose) {
  OverlapScore out;
  if (points.empty() || seen.empty()) return out;
  const double c = std::cos(pose.theta), s = std::sin(pose.theta);
  double sum = 0.0;
  size_t count = 0;
  for (const Eigen::Vector2f& p : points) {
    const double x = pose.x + c * p.x() - s * p.y(), y = pose.y + s * p.x() + c * p.y();
    if (!seen.Seen(x, y)) continue;
    sum += grid.Interpolate(x, y);
    ++count;
  }
  out.overlap = static_cast<double>(count) / static_cast<double>(points.size());
  out.score = count > 0 ? sum / static_cast<double>(count) : 0.0;
  return out;
}

}  // namespace waymark::laser_slam
