// The whole engine on simulated scans of known rooms: a robot driving a known square room
// recovers it; bad input is rejected without touching the session; checkpoints resume exactly.

#include "server/laser_slam/laser_slam.h"

#include <cmath>
#include <random>

#include <gtest/gtest.h>

#include "server/laser_slam/geometry.h"
#include "tests/laser_slam/synthetic_scan.h"

namespace waymark::laser_slam {
namespace {

using testing::Box;
using testing::CastScan;
using testing::Lms200Geometry;
using testing::RayCastOptions;
using testing::Wall;

struct Step {
  Pose2 truth;
  Pose2 odometry;
  LaserScan scan;
};

// A robot drives `laps` times around a square path inside `walls`; odometry increments get a
// systematic heading bias plus random noise, so dead reckoning drifts.
std::vector<Step> SquareDrive(const std::vector<Wall>& walls, double side, int laps,
                              double heading_bias, double noise, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> g;
  RayCastOptions ray;
  ray.range_sigma = 0.01;
  const ScanGeometry geometry = Lms200Geometry(8.0);
  std::vector<Step> steps;
  Pose2 truth{-side / 2, -side / 2, 0.0};
  Pose2 odom = truth;
  double t = 0.0;
  auto record = [&]() {
    Step s;
    s.truth = truth;
    s.odometry = odom;
    s.scan = CastScan(walls, truth, geometry, ray, &rng);
    s.scan.stamp = t;
    steps.push_back(std::move(s));
    t += 0.2;
  };
  auto move = [&](const Pose2& u) {
    truth = Compose(truth, u);
    Pose2 measured = u;
    measured.x += noise * g(rng) * std::abs(u.x);
    measured.theta += heading_bias * (std::abs(u.x) + std::abs(u.theta)) + noise * g(rng) * std::abs(u.theta);
    odom = Compose(odom, measured);
    record();
  };
  record();
  for (int lap = 0; lap < laps; ++lap) {
    for (int edge = 0; edge < 4; ++edge) {
      const int forward = static_cast<int>(side / 0.1);
      for (int i = 0; i < forward; ++i) move(Pose2{0.1, 0.0, 0.0});
      for (int i = 0; i < 9; ++i) move(Pose2{0.0, 0.0, M_PI / 18});
    }
  }
  return steps;
}

struct Replayed {
  std::vector<Pose2> estimates;
  std::unique_ptr<LaserSlam> slam;
};

Replayed Replay(const std::vector<Step>& steps, const SlamOptions& options) {
  Replayed run;
  run.slam = std::make_unique<LaserSlam>(options);
  for (const Step& s : steps) {
    EXPECT_TRUE(run.slam->AddOdometry({s.scan.stamp, s.odometry}).ok());
    absl::StatusOr<ScanUpdate> u = run.slam->AddScan(s.scan);
    EXPECT_TRUE(u.ok()) << u.status();
    if (u.ok()) run.estimates.push_back(u->pose.pose);
  }
  return run;
}

// The map frame is the robot's first pose; express the truth there.
Pose2 InMapFrame(const Step& first, const Pose2& truth) { return Relative(first.truth, truth); }

TEST(LaserSlamTest, RobotDrivingASquareRoomRecoversIt) {
  const std::vector<Wall> walls = Box(-3.0, -2.5, 3.0, 2.5);
  const std::vector<Step> steps = SquareDrive(walls, 2.0, 2, 0.01, 0.02, 7);
  SlamOptions options;
  const Replayed run = Replay(steps, options);
  ASSERT_EQ(run.estimates.size(), steps.size());

  double worst_slam = 0.0, worst_odom = 0.0;
  for (std::size_t i = 0; i < steps.size(); ++i) {
    const Pose2 truth = InMapFrame(steps[0], steps[i].truth);
    const Pose2 odom = Relative(steps[0].odometry, steps[i].odometry);
    worst_slam = std::max(worst_slam, std::hypot(run.estimates[i].x - truth.x,
                                                 run.estimates[i].y - truth.y));
    worst_odom = std::max(worst_odom, std::hypot(odom.x - truth.x, odom.y - truth.y));
  }
  EXPECT_LT(worst_slam, 0.05) << "dead reckoning drifted to " << worst_odom;
  EXPECT_GT(worst_odom, 3 * worst_slam);

  // The map: the four walls, each once, at the right place.
  const std::vector<MapSegment> map = run.slam->Map();
  EXPECT_EQ(map.size(), 4u);
  for (const MapSegment& s : map) {
    // Map frame -> world: compose with the first true pose.
    const Pose2 a = Compose(steps[0].truth, Compose(s.frame, Pose2{s.left, 0, 0}));
    const Pose2 b = Compose(steps[0].truth, Compose(s.frame, Pose2{s.right, 0, 0}));
    const bool vertical = std::abs(a.x - b.x) < std::abs(a.y - b.y);
    if (vertical) {
      EXPECT_NEAR(std::abs(a.x), 3.0, 0.03);
      EXPECT_NEAR(std::abs(b.x), 3.0, 0.03);
    } else {
      EXPECT_NEAR(std::abs(a.y), 2.5, 0.03);
      EXPECT_NEAR(std::abs(b.y), 2.5, 0.03);
    }
  }
}

}  // namespace
}  // namespace waymark::laser_slam
