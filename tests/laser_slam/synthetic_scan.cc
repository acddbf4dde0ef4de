#include "tests/laser_slam/synthetic_scan.h"

#include <cmath>
#include <limits>

#include "server/laser_slam/geometry.h"
#include "server/laser_slam/mapping/point_cloud.h"

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

std::vector<MapSegment> SegmentsOf(const std::vector<Wall>& walls) {
  std::vector<MapSegment> out;
  for (const Wall& w : walls) {
    out.push_back(SegmentBetween(out.size() + 1, w.a.x(), w.a.y(), w.b.x(), w.b.y(),
                                 EndpointType::kReal, EndpointType::kReal));
  }
  return out;
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

std::vector<Wall> PillarOffice() {
  std::vector<Wall> walls = Box(0.0, 0.0, 20.0, 12.0);
  for (const std::vector<Wall>& pillar : {Box(4.0, 3.0, 4.6, 3.6), Box(9.0, 8.0, 10.5, 8.4),
                                          Box(14.0, 2.0, 14.3, 4.5), Box(16.0, 8.5, 17.2, 9.7)}) {
    walls.insert(walls.end(), pillar.begin(), pillar.end());
  }
  walls.push_back({{6.0, 0.0}, {6.0, 2.5}});
  walls.push_back({{11.0, 12.0}, {11.0, 9.5}});
  walls.push_back({{0.0, 6.0}, {2.5, 6.0}});
  walls.push_back({{17.0, 5.0}, {20.0, 5.0}});
  walls.push_back({{7.0, 8.5}, {8.5, 9.7}});
  return walls;
}

std::vector<Pose2> PolylinePath(const std::vector<Eigen::Vector2d>& corners, double step) {
  std::vector<Pose2> path;
  for (size_t leg = 0; leg + 1 < corners.size(); ++leg) {
    const Eigen::Vector2d d = corners[leg + 1] - corners[leg];
    const double heading = std::atan2(d.y(), d.x());
    const int steps = static_cast<int>(d.norm() / step);
    for (int i = 0; i < steps; ++i) {
      const Eigen::Vector2d p = corners[leg] + d * (static_cast<double>(i) / steps);
      path.push_back(Pose2{p.x(), p.y(), heading});
    }
  }
  return path;
}

std::vector<Pose2> PillarOfficeLap() {
  return PolylinePath({{3.0, 5.0}, {15.5, 5.0}, {15.5, 7.5}, {3.0, 7.5}, {3.0, 5.0}}, 0.25);
}

Pose2 DriftingStep(const Pose2& own, const Pose2& from, const Pose2& to) {
  const Pose2 step = Relative(from, to);
  return Compose(own, Pose2{step.x * 1.01, step.y * 1.01, step.theta + 0.002});
}

}  // namespace waymark::laser_slam::testing
