#include "client/datasets/odometry_lag.h"

#include <fmt/format.h>

#include <cmath>
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "client/sessions/carmen_laser_source.h"
#include "tests/client/test_util.h"

namespace waymark::adapters {
namespace {

// A robot turning in place in an irregular room, seen by a 180-beam laser at 1 degree: the
// rotation between scans varies (a turn, a pause, the other way), as a robot's does.
struct Wall {
  double ax, ay, bx, by;
};

float RayRange(const std::vector<Wall>& walls, double x, double y, double bearing) {
  const double dx = std::cos(bearing), dy = std::sin(bearing);
  double best = 50.0;
  for (const Wall& w : walls) {
    const double ex = w.bx - w.ax, ey = w.by - w.ay;
    const double denom = dx * ey - dy * ex;
    if (std::abs(denom) < 1e-12) continue;
    const double t = ((w.ax - x) * ey - (w.ay - y) * ex) / denom;
    const double u = ((w.ax - x) * dy - (w.ay - y) * dx) / denom;
    if (t > 0 && u >= 0 && u <= 1) best = std::min(best, t);
  }
  return static_cast<float>(best);
}

std::vector<CarmenLaser> TurningRobot(int scans) {
  const std::vector<Wall> room = {{-3, -2, 5, -2.5}, {5, -2.5, 6, 3},  {6, 3, 1, 4},
                                  {1, 4, 1, 2.5},    {1, 2.5, -4, 3},  {-4, 3, -3, -2},
                                  {2, -1, 2.5, -0.5}};
  std::vector<CarmenLaser> lasers;
  double heading = 0.0;
  for (int i = 0; i < scans; ++i) {
    CarmenLaser l;
    l.stamp = i * 0.2;
    l.angle_min = kFlaserAngleMin;
    l.angle_increment = FlaserAngleIncrement(180);
    l.odom_pose = {0.3, 0.2, heading};
    l.laser_pose = l.odom_pose;
    for (int k = 0; k < 180; ++k) {
      l.ranges.push_back(RayRange(room, 0.3, 0.2, heading + l.angle_min + k * l.angle_increment));
    }
    lasers.push_back(l);
    heading += 0.12 * std::sin(i / 9.0) + (i % 40 < 10 ? 0.0 : 0.03);
  }
  return lasers;
}

TEST(OdometryLagTest, ScanRotationFollowsTheTurn) {
  const std::vector<CarmenLaser> lasers = TurningRobot(3);
  const double turned = lasers[2].odom_pose.theta - lasers[1].odom_pose.theta;
  EXPECT_NEAR(ScanRotation(lasers[1], lasers[2], 0.35), turned, lasers[1].angle_increment);
  EXPECT_DOUBLE_EQ(ScanRotation(lasers[1], lasers[1], 0.35), 0.0);
}

TEST(OdometryLagTest, InStepOdometryIsKept) {
  const OdometryLag lag = EstimateOdometryLag(TurningRobot(400));
  EXPECT_GT(lag.turning_pairs, 100);
  EXPECT_FALSE(lag.decided());
  EXPECT_EQ(lag.lag_scans, 0.0);
}

TEST(OdometryLagTest, OdometryOneScanAheadIsFoundAndUndone) {
  const std::vector<CarmenLaser> truth = TurningRobot(400);
  std::vector<CarmenLaser> logged = truth;
  // Each scan logged with the odometry of the scan after it.
  for (size_t i = 0; i + 1 < logged.size(); ++i) {
    logged[i].odom_pose = truth[i + 1].odom_pose;
    logged[i].laser_pose = truth[i + 1].laser_pose;
  }
  const OdometryLag lag = EstimateOdometryLag(logged);
  ASSERT_TRUE(lag.decided());
  EXPECT_NEAR(lag.lag_scans, -1.0, 0.26);
  EXPECT_GT(lag.for_lag, lag.for_in_step);
  EXPECT_LE(lag.log10_chance, kOdometryLagLog10Chance);

  ShiftOdometry(-1.0, &logged);
  for (size_t i = 1; i + 1 < logged.size(); ++i) {
    // Headings come back wrapped.
    EXPECT_NEAR(std::remainder(logged[i].odom_pose.theta - truth[i].odom_pose.theta, 2 * M_PI),
                0.0, 1e-9)
        << i;
    EXPECT_NEAR(std::remainder(logged[i].laser_pose.theta - truth[i].laser_pose.theta, 2 * M_PI),
                0.0, 1e-9)
        << i;
  }
}

TEST(OdometryLagTest, ShiftInterpolatesBetweenScans) {
  std::vector<CarmenLaser> lasers(3);
  for (int i = 0; i < 3; ++i) lasers[i].odom_pose = {1.0 * i, 0.0, 0.1 * i};
  ShiftOdometry(0.5, &lasers);
  EXPECT_NEAR(lasers[0].odom_pose.x, 0.5, 1e-12);
  EXPECT_NEAR(lasers[1].odom_pose.theta, 0.15, 1e-12);
  EXPECT_NEAR(lasers[2].odom_pose.x, 2.0, 1e-12);  // clamped at the end
}

// A replay's source reads the log once for the lag, then sends each scan with its own odometry
// and says what it did.
TEST(OdometryLagTest, ReplaySourceMovesTheOdometryBackAndSaysSo) {
  const std::vector<CarmenLaser> truth = TurningRobot(300);
  testing::ScopedTempDir dir;
  const std::string path = (dir.path() / "ahead.clf").string();
  {
    std::ofstream log(path);
    for (size_t i = 0; i < truth.size(); ++i) {
      const CarmenPose& ahead = truth[std::min(i + 1, truth.size() - 1)].odom_pose;
      log << "FLASER " << truth[i].ranges.size();
      for (float r : truth[i].ranges) log << fmt::format(" {:.3f}", r);
      log << fmt::format(" {0:.9f} {1:.9f} {2:.9f} {0:.9f} {1:.9f} {2:.9f} {3} nohost {3}\n",
                         ahead.x, ahead.y, ahead.theta, 1.0 + 0.2 * i);
    }
  }
  auto source = cli::CarmenLaserSource::Open(path, 0, std::nullopt);
  ASSERT_TRUE(source.ok()) << source.status();
  const std::vector<std::string> warnings = (*source)->Warnings();
  ASSERT_EQ(warnings.size(), 1u);
  EXPECT_NE(warnings[0].find("odometry of the scan 1 after it"), std::string::npos) << warnings[0];
  LaserSample sample;
  for (size_t i = 0; i < truth.size(); ++i) {
    auto more = (*source)->Next(&sample);
    ASSERT_TRUE(more.ok() && *more) << i;
    if (i == 0) continue;  // the first scan has no odometry before it: it keeps its own
    EXPECT_NEAR(std::remainder(sample.odom.theta - truth[i].odom_pose.theta, 2 * M_PI), 0.0, 1e-6)
        << i;
  }
  // Told to keep the log's pairing, it does, and says nothing.
  auto as_logged = cli::CarmenLaserSource::Open(path, 0, 0);
  ASSERT_TRUE(as_logged.ok());
  EXPECT_TRUE((*as_logged)->Warnings().empty());
}

// --- the real logs (../shared/data/laser; skipped when absent) ---

std::string LaserLog(const std::string& relative) {
  return (std::filesystem::path(WAYMARK_SHARED_DIR) / "data" / "laser" / relative).string();
}

// MIT Killian as MOLA's rawlog gives it back pairs each scan with the next scan's odometry
// (docs/results.md, issue 33's tenth part); the other raw logs pair them as recorded.
TEST(OdometryLagRealLogTest, KillianIsOneScanAheadAndTheOthersAreInStep) {
  const std::string killian = LaserLog("mit-killian/mit-killian_from_rawlog_SYNTHETIC_TIME.clf.gz");
  if (!std::filesystem::exists(killian)) {
    GTEST_SKIP() << "../shared/data/laser is absent: real-data check skipped";
  }
  const absl::StatusOr<OdometryLag> lag = EstimateOdometryLagOfLog(killian);
  ASSERT_TRUE(lag.ok()) << lag.status();
  EXPECT_EQ(lag->lag_scans, -1);
  EXPECT_LE(lag->log10_chance, -20.0);
  for (const char* log : {"aces/aces.clf.bz2", "intel/intel.clf.bz2", "mit-csail/mit-csail.clf.bz2",
                          "fr-clinic/fr-clinic_robotlaser.clf.bz2"}) {
    const absl::StatusOr<OdometryLag> in_step = EstimateOdometryLagOfLog(LaserLog(log));
    ASSERT_TRUE(in_step.ok()) << log << ": " << in_step.status();
    EXPECT_EQ(in_step->lag_scans, 0) << log;
    EXPECT_GT(in_step->turning_pairs, 200) << log;
  }
}

}  // namespace
}  // namespace waymark::adapters
