#include "client/sim/sim_geometry.h"

#include <algorithm>
#include <cmath>
#include <limits>

namespace waymark::adapters::geometry {
namespace {

constexpr double kInfinity = std::numeric_limits<double>::infinity();
constexpr double kTwoPi = 6.28318530717958647692;

double Cross(double ax, double ay, double bx, double by) { return ax * by - ay * bx; }

}  // namespace

double PointSegmentDistance(double px, double py, const Wall& wall) {
  const double ex = wall.x2 - wall.x1;
  const double ey = wall.y2 - wall.y1;
  const double length2 = ex * ex + ey * ey;
  double u = 0;
  if (length2 > 0) u = std::clamp(((px - wall.x1) * ex + (py - wall.y1) * ey) / length2, 0.0, 1.0);
  return std::hypot(px - (wall.x1 + u * ex), py - (wall.y1 + u * ey));
}

double Clearance(const std::vector<Wall>& walls, double px, double py) {
  double nearest = kInfinity;
  for (const Wall& wall : walls) nearest = std::min(nearest, PointSegmentDistance(px, py, wall));
  return nearest;
}

double RaySegmentHit(double ox, double oy, double dx, double dy, const Wall& wall) {
  // Solve (ox, oy) + t d = (x1, y1) + u e for t >= 0 and u in [0, 1].
  const double ex = wall.x2 - wall.x1;
  const double ey = wall.y2 - wall.y1;
  const double denominator = Cross(dx, dy, ex, ey);
  if (std::abs(denominator) <= 1e-12 * std::hypot(ex, ey)) return kInfinity;  // parallel
  const double wx = wall.x1 - ox;
  const double wy = wall.y1 - oy;
  const double t = Cross(wx, wy, ex, ey) / denominator;
  const double u = Cross(wx, wy, dx, dy) / denominator;
  if (t < 0 || u < 0 || u > 1) return kInfinity;
  return t;
}

double CastRay(const std::vector<Wall>& walls, double ox, double oy, double dx, double dy) {
  double nearest = kInfinity;
  for (const Wall& wall : walls) nearest = std::min(nearest, RaySegmentHit(ox, oy, dx, dy, wall));
  return nearest;
}

double WrapAngle(double angle) { return std::remainder(angle, kTwoPi); }

BasePose Compose(const BasePose& frame, const BasePose& local) {
  const double c = std::cos(frame.theta);
  const double s = std::sin(frame.theta);
  return BasePose{frame.x + c * local.x - s * local.y, frame.y + s * local.x + c * local.y,
                  WrapAngle(frame.theta + local.theta)};
}

void ApplyArc(BasePose& pose, double distance, double turn) {
  // The chord of the arc points along the mean heading; its length is 2 (d / turn) sin(turn / 2).
  const double half = turn / 2;
  const double chord = std::abs(half) < 1e-9 ? distance : distance * std::sin(half) / half;
  pose.x += chord * std::cos(pose.theta + half);
  pose.y += chord * std::sin(pose.theta + half);
  pose.theta = WrapAngle(pose.theta + turn);
}

}  // namespace waymark::adapters::geometry
