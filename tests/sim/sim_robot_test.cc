#include "client/sim/sim_robot.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "absl/status/status.h"

namespace waymark::adapters {
namespace {

constexpr double kPi = 3.14159265358979323846;

// A square room of half-size `half` centred on the origin; the robot at `start`.
World Room(double half, BasePose start = {}) {
  World world;
  world.name = "room";
  world.start = start;
  world.walls = {{-half, -half, half, -half},
                 {half, -half, half, half},
                 {half, half, -half, half},
                 {-half, half, -half, -half}};
  return world;
}

SimOptions Exact() {
  SimOptions options;
  options.odometry = OdometryError{1.0, 1.0, 0.0, 0.0, 0.0, 0.0};
  options.range_sigma = 0;
  return options;
}

TEST(SimulationTest, StraightDriveAndExactOdometry) {
  Simulation sim(Room(5), Exact());
  ASSERT_TRUE(sim.base().SetVelocity(0.15, 0).ok());
  sim.Advance(10);
  EXPECT_DOUBLE_EQ(sim.now(), 10);
  EXPECT_NEAR(sim.true_pose().x, 1.5, 1e-9);
  EXPECT_NEAR(sim.true_pose().y, 0, 1e-12);
  EXPECT_NEAR(sim.distance_travelled(), 1.5, 1e-9);
  EXPECT_EQ(sim.odometry_pose().x, sim.true_pose().x);
  EXPECT_EQ(sim.odometry_pose().y, sim.true_pose().y);
  EXPECT_EQ(sim.odometry_pose().theta, sim.true_pose().theta);
  absl::StatusOr<BaseState> state = sim.base().Read();
  ASSERT_TRUE(state.ok());
  EXPECT_DOUBLE_EQ(state->stamp, 10);
  EXPECT_DOUBLE_EQ(state->linear, 0.15);
  EXPECT_EQ(state->odometry.x, sim.true_pose().x);
  EXPECT_FALSE(state->bumped);
  EXPECT_FALSE(state->stalled);
  EXPECT_TRUE(state->motors_enabled);
  EXPECT_EQ(sim.collisions(), 0);
}

TEST(SimulationTest, ArcIsExactAndOdometryFollowsIt) {
  SimOptions options = Exact();
  options.step = 0.5;  // exact arc integration: the step size does not matter
  Simulation sim(Room(5), options);
  ASSERT_TRUE(sim.base().SetVelocity(0.15, 0.17).ok());
  sim.Advance(7.3);  // 14 steps and a shorter one
  const double r = 0.15 / 0.17, a = 0.17 * 7.3;
  EXPECT_NEAR(sim.true_pose().x, r * std::sin(a), 1e-9);
  EXPECT_NEAR(sim.true_pose().y, r * (1 - std::cos(a)), 1e-9);
  EXPECT_NEAR(sim.true_pose().theta, a, 1e-9);
  EXPECT_DOUBLE_EQ(sim.now(), 7.3);
  EXPECT_EQ(sim.odometry_pose().x, sim.true_pose().x);
  EXPECT_EQ(sim.odometry_pose().theta, sim.true_pose().theta);
}

TEST(SimulationTest, SystematicDistanceScale) {
  SimOptions options = Exact();
  options.odometry.distance_scale = 1.1;
  Simulation sim(Room(5), options);
  ASSERT_TRUE(sim.base().SetVelocity(0.15, 0).ok());
  sim.Advance(10);
  EXPECT_NEAR(sim.true_pose().x, 1.5, 1e-9);
  EXPECT_NEAR(sim.odometry_pose().x, 1.65, 1e-9);
}

TEST(SimulationTest, SystematicTurnScaleAndDrift) {
  SimOptions options = Exact();
  options.odometry.turn_scale = 1.5;
  Simulation turn(Room(5), options);
  ASSERT_TRUE(turn.base().SetVelocity(0, 0.1).ok());
  turn.Advance(5);
  EXPECT_NEAR(turn.true_pose().theta, 0.5, 1e-9);
  EXPECT_NEAR(turn.odometry_pose().theta, 0.75, 1e-9);

  options = Exact();
  options.odometry.drift_per_m = 0.01;
  Simulation drift(Room(5), options);
  ASSERT_TRUE(drift.base().SetVelocity(0.15, 0).ok());
  drift.Advance(20);
  EXPECT_NEAR(drift.true_pose().theta, 0, 1e-12);
  EXPECT_NEAR(drift.odometry_pose().theta, 0.03, 1e-9);
}

// The random odometry error over a path does not depend on the step size: its standard deviation
// over 1 m is distance_sigma.
TEST(SimulationTest, RandomDistanceErrorScalesWithDistanceNotSteps) {
  for (double step : {0.01, 0.2}) {
    SCOPED_TRACE(step);
    double sum = 0, sum2 = 0;
    const int runs = 300;
    for (int seed = 1; seed <= runs; ++seed) {
      SimOptions options = Exact();
      options.seed = seed;
      options.step = step;
      options.odometry.distance_sigma = 0.02;
      Simulation sim(Room(5), options);
      ASSERT_TRUE(sim.base().SetVelocity(0.1, 0).ok());
      sim.Advance(10);
      const double error = sim.odometry_pose().x - sim.true_pose().x;
      sum += error;
      sum2 += error * error;
    }
    const double mean = sum / runs;
    const double sigma = std::sqrt(sum2 / runs - mean * mean);
    EXPECT_NEAR(sigma, 0.02, 0.004);
    EXPECT_NEAR(mean, 0, 0.004);
  }
}

TEST(SimulationTest, VelocityIsClampedToTheLimits) {
  Simulation sim(Room(5), Exact());
  EXPECT_DOUBLE_EQ(sim.base().max_linear(), 0.15);
  EXPECT_DOUBLE_EQ(sim.base().max_angular(), 0.17);
  ASSERT_TRUE(sim.base().SetVelocity(1.0, 0).ok());
  sim.Advance(1);
  EXPECT_NEAR(sim.true_pose().x, 0.15, 1e-12);
  EXPECT_DOUBLE_EQ(sim.base().Read()->linear, 0.15);
  ASSERT_TRUE(sim.base().SetVelocity(-1.0, -1.0).ok());
  sim.Advance(1);
  EXPECT_DOUBLE_EQ(sim.base().Read()->linear, -0.15);
  EXPECT_DOUBLE_EQ(sim.base().Read()->angular, -0.17);
  EXPECT_NEAR(sim.true_pose().theta, -0.17, 1e-12);
  ASSERT_TRUE(sim.base().Stop().ok());
  const BasePose before = sim.true_pose();
  sim.Advance(3);
  EXPECT_EQ(sim.true_pose().x, before.x);
  EXPECT_EQ(sim.true_pose().theta, before.theta);
  EXPECT_EQ(sim.base().Read()->linear, 0);

  EXPECT_EQ(sim.base().SetVelocity(std::nan(""), 0).code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(sim.base().SetVelocity(0, std::numeric_limits<double>::infinity()).code(),
            absl::StatusCode::kInvalidArgument);
}

TEST(SimulationTest, DrivingIntoAWallStopsAtBodyRadiusAndCountsOneCollision) {
  Simulation sim(Room(5, {3, 0, 0}), Exact());
  ASSERT_TRUE(sim.base().SetVelocity(0.15, 0).ok());
  sim.Advance(30);  // would drive 4.5 m; the wall is 2 m away
  const double radius = sim.options().body_radius;
  const double gap = 5 - sim.true_pose().x;
  EXPECT_GE(gap, radius);
  EXPECT_LE(gap, radius + 0.15 * 0.01 + 1e-9);
  EXPECT_TRUE(sim.bumped());
  EXPECT_EQ(sim.collisions(), 1);
  absl::StatusOr<BaseState> state = sim.base().Read();
  EXPECT_TRUE(state->bumped);
  EXPECT_EQ(state->linear, 0);
  EXPECT_NEAR(sim.distance_travelled(), 2 - gap, 1e-9);
  EXPECT_NEAR(sim.odometry_pose().x, sim.true_pose().x, 1e-9);

  // Standing still or pushing on is the same contact.
  ASSERT_TRUE(sim.base().Stop().ok());
  sim.Advance(1);
  ASSERT_TRUE(sim.base().SetVelocity(0.15, 0).ok());
  sim.Advance(5);
  EXPECT_EQ(sim.collisions(), 1);

  // Backing off ends it; driving in again is a second one.
  ASSERT_TRUE(sim.base().SetVelocity(-0.15, 0).ok());
  sim.Advance(2);
  EXPECT_FALSE(sim.bumped());
  EXPECT_NEAR(5 - sim.true_pose().x, gap + 0.3, 1e-9);
  ASSERT_TRUE(sim.base().SetVelocity(0.15, 0).ok());
  sim.Advance(5);
  EXPECT_TRUE(sim.bumped());
  EXPECT_EQ(sim.collisions(), 2);
}

TEST(SimulationTest, RotationInPlaceNextToAWallIsAllowed) {
  Simulation sim(Room(5, {4.5, 0, 0}), Exact());
  ASSERT_TRUE(sim.base().SetVelocity(0.15, 0).ok());
  sim.Advance(5);
  ASSERT_TRUE(sim.bumped());
  const BasePose touching = sim.true_pose();
  ASSERT_TRUE(sim.base().SetVelocity(0, 0.17).ok());
  sim.Advance(5);
  EXPECT_EQ(sim.true_pose().x, touching.x);
  EXPECT_EQ(sim.true_pose().y, touching.y);
  EXPECT_NEAR(sim.true_pose().theta, 0.85, 1e-9);
  // Pushing into the wall while turning: the turn happens, the translation does not (beyond
  // the last millimetre to the wall), and it is still the same contact.
  ASSERT_TRUE(sim.base().SetVelocity(0.15, 0.17).ok());
  sim.Advance(0.05);
  EXPECT_GE(5 - sim.true_pose().x, sim.options().body_radius);
  EXPECT_LE(sim.true_pose().x, touching.x + 0.0015);
  EXPECT_NEAR(sim.true_pose().theta, 0.85 + 0.17 * 0.05, 1e-9);
  EXPECT_TRUE(sim.bumped());
  EXPECT_EQ(sim.collisions(), 1);
  // Turned away from the wall, it drives off and the contact ends.
  ASSERT_TRUE(sim.base().SetVelocity(0, 0.17).ok());
  sim.Advance((kPi - 0.85 - 0.17 * 0.05) / 0.17);
  EXPECT_NEAR(std::abs(sim.true_pose().theta), kPi, 1e-9);
  const BasePose turned = sim.true_pose();
  ASSERT_TRUE(sim.base().SetVelocity(0.15, 0).ok());
  sim.Advance(2);
  EXPECT_NEAR(sim.true_pose().x, turned.x - 0.3, 1e-9);
  EXPECT_FALSE(sim.bumped());
  EXPECT_EQ(sim.collisions(), 1);
}

TEST(SimulationTest, AdvanceTakesAShorterLastStep) {
  SimOptions options = Exact();
  options.step = 0.3;
  Simulation sim(Room(5), options);
  ASSERT_TRUE(sim.base().SetVelocity(0.1, 0).ok());
  sim.Advance(1.0);
  EXPECT_DOUBLE_EQ(sim.now(), 1.0);
  EXPECT_NEAR(sim.true_pose().x, 0.1, 1e-12);
  sim.Advance(0);
  sim.Advance(-1);
  EXPECT_DOUBLE_EQ(sim.now(), 1.0);
}

TEST(LaserTest, LayoutAndStraightAheadBeam) {
  Simulation sim(Room(5), Exact());
  const LaserLayout layout = sim.laser().layout();
  EXPECT_EQ(layout.beam_count, 181u);
  EXPECT_DOUBLE_EQ(layout.angle_min, -kPi / 2);
  EXPECT_DOUBLE_EQ(layout.angle_increment, kPi / 180);
  EXPECT_DOUBLE_EQ(layout.no_return_range, 8.183);
  EXPECT_DOUBLE_EQ(layout.mount.x, 0.16);
  absl::StatusOr<LaserReading> scan = sim.laser().Read();
  ASSERT_TRUE(scan.ok());
  ASSERT_EQ(scan->ranges.size(), 181u);
  EXPECT_FLOAT_EQ(scan->ranges[90], 4.84f);  // front wall 5 m, laser 0.16 m ahead of the centre
  EXPECT_FLOAT_EQ(scan->ranges[0], 5.0f);    // right
  EXPECT_FLOAT_EQ(scan->ranges[180], 5.0f);  // left

  SimOptions noisy;  // default noise: 1 cm
  Simulation noisy_sim(Room(5), noisy);
  for (int i = 0; i < 20; ++i) EXPECT_NEAR(noisy_sim.Scan().ranges[90], 4.84, 0.05);
}

// Distance from (x, y) along `angle` to the walls of Room(half).
double BoxDistance(double half, double x, double y, double angle) {
  const double c = std::cos(angle), s = std::sin(angle);
  double t = std::numeric_limits<double>::infinity();
  if (c > 1e-12) t = std::min(t, (half - x) / c);
  if (c < -1e-12) t = std::min(t, (-half - x) / c);
  if (s > 1e-12) t = std::min(t, (half - y) / s);
  if (s < -1e-12) t = std::min(t, (-half - y) / s);
  return t;
}

TEST(LaserTest, ExactRangesToTheMillimetre) {
  for (bool half_degree : {false, true}) {
    SimOptions options = Exact();
    options.half_degree = half_degree;
    options.laser_mount = BasePose{0.16, 0.03, 0.1};
    const BasePose start{0.4321, -1.234, 2.5};
    Simulation sim(Room(3, start), options);
    const LaserReading scan = sim.Scan();
    const LaserLayout layout = sim.laser_layout();
    ASSERT_EQ(scan.ranges.size(), half_degree ? 361u : 181u);
    EXPECT_DOUBLE_EQ(layout.angle_increment, half_degree ? kPi / 360 : kPi / 180);
    const double lx = start.x + std::cos(start.theta) * 0.16 - std::sin(start.theta) * 0.03;
    const double ly = start.y + std::sin(start.theta) * 0.16 + std::cos(start.theta) * 0.03;
    for (size_t i = 0; i < scan.ranges.size(); ++i) {
      const double angle = start.theta + 0.1 + layout.angle_min + i * layout.angle_increment;
      const double expected = BoxDistance(3, lx, ly, angle);
      ASSERT_LT(expected, 8.0);
      EXPECT_NEAR(scan.ranges[i], expected, 0.0005 + 1e-6) << "beam " << i;
      // Quantised to millimetres.
      const double mm = scan.ranges[i] * 1000.0;
      EXPECT_NEAR(mm, std::round(mm), 1e-3) << "beam " << i;
    }
  }
}

TEST(LaserTest, BeyondMaxRangeReadsNoReturn) {
  Simulation sim(Room(20), SimOptions{});
  const LaserReading scan = sim.Scan();
  ASSERT_EQ(scan.ranges.size(), 181u);
  for (float range : scan.ranges) EXPECT_EQ(range, static_cast<float>(8.183));

  World empty = Room(1);
  empty.walls.clear();
  Simulation nothing(empty, SimOptions{});
  for (float range : nothing.Scan().ranges) EXPECT_EQ(range, static_cast<float>(8.183));
}

TEST(LaserTest, StampIsSimulatedTime) {
  Simulation sim(Room(5), SimOptions{});
  sim.Advance(2.5);
  EXPECT_DOUBLE_EQ(sim.laser().Read()->stamp, 2.5);
}

struct Recording {
  std::vector<std::vector<float>> scans;
  std::vector<double> odometry;
};

Recording Drive(std::uint64_t seed) {
  SimOptions options;  // default noise everywhere
  options.seed = seed;
  absl::StatusOr<World> world = LoadWorld("corridor");
  EXPECT_TRUE(world.ok());
  Simulation sim(*world, options);
  Recording run;
  EXPECT_TRUE(sim.base().SetVelocity(0.15, 0.05).ok());
  for (int i = 0; i < 20; ++i) {
    sim.Advance(1);
    run.scans.push_back(sim.Scan().ranges);
    const BaseState state = *sim.base().Read();
    run.odometry.insert(run.odometry.end(),
                        {state.odometry.x, state.odometry.y, state.odometry.theta});
  }
  return run;
}

TEST(SimulationTest, SameSeedSameRunDifferentSeedDifferentRun) {
  const Recording a = Drive(7), b = Drive(7), c = Drive(8);
  EXPECT_EQ(a.scans, b.scans);
  EXPECT_EQ(a.odometry, b.odometry);
  EXPECT_NE(a.scans, c.scans);
  EXPECT_NE(a.odometry, c.odometry);
}

}  // namespace
}  // namespace waymark::adapters

namespace waymark::adapters {
namespace {

// Several robots in one world (client/sessions/sim_team_explore.h): another robot is a disc the
// laser sees and the base bumps into, and a robot may start elsewhere than the world's start.
TEST(SimulationTest, OtherRobotsAreSeenAndBumpedInto) {
  SimOptions options = Exact();
  options.start = BasePose{-1.0, 0.0, 0.0};
  Simulation sim(Room(5), options);
  EXPECT_DOUBLE_EQ(sim.true_pose().x, -1.0);
  const size_t ahead = 90;  // the straight-ahead beam of 181
  const double wall = sim.Scan().ranges[ahead];
  EXPECT_NEAR(wall, 5.0 + 1.0 - 0.16, 1e-3);
  sim.SetOtherBodies({OtherBody{1.0, 0.0, 0.25}});
  EXPECT_NEAR(sim.Scan().ranges[ahead], 2.0 - 0.16 - 0.25, 1e-3);
  ASSERT_TRUE(sim.base().SetVelocity(0.15, 0).ok());
  sim.Advance(20);
  EXPECT_TRUE(sim.bumped());
  EXPECT_EQ(sim.collisions(), 1);
  EXPECT_NEAR(sim.true_pose().x, 1.0 - 0.25 - options.body_radius, 0.01);
  sim.SetOtherBodies({});
  EXPECT_NEAR(sim.Scan().ranges[ahead], 5.0 - sim.true_pose().x - 0.16, 1e-3);
}

}  // namespace
}  // namespace waymark::adapters
