#include "tests/laser_slam/synthetic_scan.h"

#include "server/laser_slam/mapping/point_cloud.h"

#include <cmath>
#include <limits>

namespace waymark::laser_slam::testing {

ScanGeometry Lms200Geometry(double no_return_range) {
  ScanGeometry g;
  g.angle_min = -M_PI / 2;
  g.angle_increment = M_PI / 360;
  g.beam_count = 361;
  g.no_return_range = no_return_range;
  return g;
}

ScanGeometry Lms200OneDegreeGeometry() {
  ScanGeometry g;
  g.angle_min = -M_PI / 2;
  g.angle_increment = M_PI / 180;
  g.beam_count = 181;
  g.no_return_range = 8.183;
  return g;
}

MapSegment SegmentBetween(std::uint64_t id, double x1, double y1, double x2, double y2,
                          EndpointType left_type, EndpointType right_type) {
  MapSegment s;
  s.id = id;
  const Eigen::Vector2d d(x2 - x1, y2 - y1);
  const double length = d.norm();
  s.frame = Pose2{(x1 + x2) / 2, (y1 + y2) / 2, std::atan2(d.y(), d.x())};
  s.left = -length / 2;
  s.right = length / 2;
  s.left_type = left_type;
  s.right_type = right_type;
  return s;
}

double CastRay(const std::vector<Wall>& walls, const Eigen::Vector2d& origin, double angle) {
  const Eigen::Vector2d d(std::cos(angle), std::sin(angle));
  double best = -1.0;
  for (const Wall& w : walls) {
    // origin + t d = a + u (b - a), t > 0, u in [0, 1].
    const Eigen::Vector2d e = w.b - w.a;
    const double den = d.x() * (-e.y()) - d.y() * (-e.x());
    if (std::abs(den) < 1e-12) continue;
    const Eigen::Vector2d r = w.a - origin;
    const double t = (r.x() * (-e.y()) - r.y() * (-e.x())) / den;
    const double u = (d.x() * r.y() - d.y() * r.x()) / den;
    if (t > 1e-9 && u >= 0.0 && u <= 1.0 && (best < 0.0 || t < best)) best = t;
  }
  return best;
}

LaserScan CastScan(const std::vector<Wall>& walls, const Pose2& laser_pose,
                   const ScanGeometry& geometry, const RayCastOptions& options, std::mt19937* rng) {
  LaserScan scan;
  scan.geometry = geometry;
  scan.ranges.resize(geometry.beam_count);
  std::normal_distribution<double> normal(0.0, 1.0);
  const Eigen::Vector2d origin(laser_pose.x, laser_pose.y);
  const float miss = geometry.no_return_range > 0.0 ? static_cast<float>(geometry.no_return_range)
                                                    : std::numeric_limits<float>::infinity();
  for (int i = 0; i < geometry.beam_count; ++i) {
    double a = laser_pose.theta + geometry.angle_min + i * geometry.angle_increment;
    if (options.bearing_sigma > 0.0) a += options.bearing_sigma * normal(*rng);
    double r = CastRay(walls, origin, a);
    if (r < 0.0 || r > options.sensor_range) {
      scan.ranges[i] = miss;
      continue;
    }
    if (options.range_sigma > 0.0) r += options.range_sigma * normal(*rng);
    scan.ranges[i] = static_cast<float>(r);
  }
  return scan;
}

std::vector<Eigen::Vector2f> ScanPoints(const std::vector<Wall>& walls, const Pose2& pose) {
  RayCastOptions ray;
  ray.sensor_range = 12.0;
  const LaserScan scan = CastScan(walls, pose, Lms200Geometry(), ray, nullptr);
  return ScanToPoints(scan, Pose2{}, 0.05, 12.0);
}

std::vector<Wall> Box(double x0, double y0, double x1, double y1) {
  return {{{x0, y0}, {x1, y0}}, {{x1, y0}, {x1, y1}}, {{x1, y1}, {x0, y1}}, {{x0, y1}, {x0, y0}}};
}

}  // namespace waymark::laser_slam::testing
