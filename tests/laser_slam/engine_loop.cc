#include "tests/laser_slam/engine_loop.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <utility>

#include <gtest/gtest.h>

#include "server/laser_slam/geometry.h"
#include "server/laser_slam/motion.h"

namespace waymark::laser_slam::testing {

Wall W(double x1, double y1, double x2, double y2) {
  return Wall{Eigen::Vector2d(x1, y1), Eigen::Vector2d(x2, y2)};
}

double DistanceToWalls(const std::vector<Wall>& walls, const Eigen::Vector2d& p) {
  double best = std::numeric_limits<double>::infinity();
  for (const Wall& w : walls) {
    const Eigen::Vector2d ab = w.b - w.a;
    const double t = std::clamp((p - w.a).dot(ab) / ab.squaredNorm(), 0.0, 1.0);
    best = std::min(best, (w.a + t * ab - p).norm());
  }
  return best;
}

EngineLoop::EngineLoop(std::vector<Wall> walls, const Pose2& start, const SlamOptions& options)
    : walls_(std::move(walls)), truth_(start), start_(start), slam_(options) {}

ScanUpdate EngineLoop::Observe() {
  t_ += 0.1;
  EXPECT_TRUE(slam_.AddOdometry({t_, Relative(start_, truth_)}).ok());
  LaserScan scan = CastScan(walls_, truth_, Lms200OneDegreeGeometry(), RayCastOptions{}, nullptr);
  scan.stamp = t_;
  absl::StatusOr<ScanUpdate> u = slam_.AddScan(scan);
  EXPECT_TRUE(u.ok()) << u.status();
  return u.ok() ? *std::move(u) : ScanUpdate{};
}

double EngineLoop::Apply(const Suggestion& s) {
  double closest = std::numeric_limits<double>::infinity();
  const int steps = static_cast<int>(std::round(s.duration / 0.1));
  for (int k = 0; k < steps; ++k) {
    truth_ = Compose(truth_, UnicycleArc(s.linear, s.angular, 0.1));
    closest = std::min(closest, DistanceToWalls(walls_, Eigen::Vector2d(truth_.x, truth_.y)));
    t_ += 0.1;
    EXPECT_TRUE(slam_.AddOdometry({t_, Relative(start_, truth_)}).ok());
  }
  return closest;
}

}  // namespace waymark::laser_slam::testing
