// Accuracy floors of the laser SLAM engine on real logs (issue 33, "real-data floors in make
// test"): the engine in-process with its default options, as waymark-laser-eval runs it
// (bench/laser/laser_slam_eval.cc), scored with the relations metric (Kummerle et al. 2009). Logs
// from ../shared/data/laser, read in place; every test skips when they are absent.
//
//   - ACES raw, its first 2000 scans, against the published relations (the full log takes 30-40 s
//     on the shared 2-core machine; its first 2000 scans cover 296 of the 1279 relations);
//   - MIT Killian's first 7000 scans against its relations restamped by the fitted scan clock;
//   - noisy-odometry rows made here exactly as bench/laser/laser_benchmark.sh makes them
//     (bench/laser/laser_reference.cc `noisy`, seed 1, medium strength): the keyframes of a
//     GMapping-corrected log with odometry regenerated with seeded error
//     (client/eval/odometry_noise.h), written as FLASER lines and parsed back (the bench's text
//     precision), scored against relations built from the corrected poses
//     (client/eval/relation_builder.h). The medium odometry is off by 1.4-3.9 m over all
//     relations: without working loop closure and local matching these rows fail.
//
// Each floor is about 1.5 times the error measured on 2026-12-05 (the measurement beside it: the
// larger of build 2b11249 and of its working tree with the uncommitted mapping changes of that
// day, which moved aces-corrected-medium from 0.064 to 0.079 m and the rest by under 0.001 m), so
// that a real regression fails and the noise of a changed constant does not. With the back end
// off (`mapping.enabled = false`, the paper's EKF alone) every noisy row fails its floor. The
// floors are behaviour, never time: nothing here looks at a clock. Run alone: `ctest -L
// real_data`; 20-40 s for the five tests on the shared 2-core machine at load 4-5.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iostream>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "client/datasets/carmen_keyframes.h"
#include "client/datasets/carmen_log.h"
#include "client/eval/odometry_noise.h"
#include "client/eval/relation_builder.h"
#include "client/eval/relations_metric.h"
#include "client/eval/scan_clock_fit.h"
#include "server/laser_slam/laser_slam.h"
#include "server/laser_slam/options.h"

namespace waymark {
namespace {

namespace ls = waymark::laser_slam;
using adapters::CarmenLaser;

constexpr double kLocalRelationS = 10.0;  // "local" relations, as waymark-laser-eval's

std::filesystem::path LaserData() {
  return std::filesystem::path(WAYMARK_SHARED_DIR) / "data" / "laser";
}

// The laser lines of a log as waymark-laser-eval reads them: all of them, stable-sorted by stamp,
// a line whose stamp repeats the previous one dropped; then the first max_scans (0: all).
std::vector<CarmenLaser> SortedLasers(std::vector<CarmenLaser> lasers, size_t max_scans) {
  std::stable_sort(lasers.begin(), lasers.end(),
                   [](const CarmenLaser& a, const CarmenLaser& b) { return a.stamp < b.stamp; });
  std::vector<CarmenLaser> unique;
  for (CarmenLaser& laser : lasers) {
    if (!unique.empty() && !(laser.stamp > unique.back().stamp)) continue;
    unique.push_back(std::move(laser));
  }
  if (max_scans > 0 && unique.size() > max_scans) unique.resize(max_scans);
  return unique;
}

absl::StatusOr<std::vector<CarmenLaser>> ReadLog(const std::string& path, size_t max_scans) {
  auto reader = adapters::CarmenLogReader::Open(path);
  if (!reader.ok()) return reader.status();
  std::vector<CarmenLaser> lasers;
  adapters::CarmenRecord record;
  while (true) {
    absl::StatusOr<bool> more = (*reader)->Next(&record);
    if (!more.ok()) return more.status();
    if (!*more) break;
    if (record.type == adapters::CarmenRecord::Type::kLaser) lasers.push_back(record.laser);
  }
  return SortedLasers(std::move(lasers), max_scans);
}

// The laser's mounting from the first line, as `slam replay` and the eval take it
// (cli::LaserMount in client/sessions/slam_replay.cc; that library is the robot side's).
ls::Pose2 Mount(const CarmenLaser& first) {
  const cli::Pose2 odom{first.odom_pose.x, first.odom_pose.y, first.odom_pose.theta};
  const cli::Pose2 sensor{first.laser_pose.x, first.laser_pose.y, first.laser_pose.theta};
  const cli::Pose2 mount = cli::Compose(cli::Inverse(odom), sensor);
  if (std::hypot(mount.x, mount.y) < 1.0 && std::abs(mount.theta) < 0.1) {
    return {mount.x, mount.y, mount.theta};
  }
  return {};
}

struct Scores {
  cli::RelationsResult all;
  cli::RelationsResult local;
  cli::RelationsResult odometry_all;
};

// Per line AddOdometry (the odometry embedded in the line) then AddScan, as the eval and `slam
// replay` send them; the back end's last optimisation; the final trajectory scored.
Scores RunAndScore(const std::vector<CarmenLaser>& lasers,
                   const std::vector<cli::Relation>& relations, const ls::SlamOptions& base) {
  ls::SlamOptions options = base;
  options.laser_pose = Mount(lasers.front());
  EXPECT_TRUE(ls::ValidateSlamOptions(options).ok());
  ls::LaserSlam slam(options);
  std::vector<cli::StampedPose> odometry;
  for (const CarmenLaser& laser : lasers) {
    ls::OdometryReading reading;
    reading.stamp = laser.stamp;
    reading.pose = {laser.odom_pose.x, laser.odom_pose.y, laser.odom_pose.theta};
    odometry.push_back({laser.stamp, {reading.pose.x, reading.pose.y, reading.pose.theta}});
    ls::LaserScan scan;
    scan.stamp = laser.stamp;
    scan.geometry.angle_min = laser.angle_min;
    scan.geometry.angle_increment = laser.angle_increment;
    scan.geometry.beam_count = static_cast<int>(laser.ranges.size());
    scan.geometry.no_return_range = laser.no_return_range;
    scan.ranges = laser.ranges;
    EXPECT_TRUE(slam.AddOdometry(reading).ok());
    absl::StatusOr<ls::ScanUpdate> update = slam.AddScan(scan);
    EXPECT_TRUE(update.ok()) << update.status();
  }
  slam.FlushBackend();
  std::vector<cli::StampedPose> trajectory;
  for (const ls::PoseEstimate& p : slam.Trajectory()) {
    trajectory.push_back({p.stamp, {p.pose.x, p.pose.y, p.pose.theta}});
  }
  std::vector<cli::Relation> local;
  for (const cli::Relation& r : relations) {
    if (std::abs(r.t2 - r.t1) <= kLocalRelationS) local.push_back(r);
  }
  return {cli::EvaluateRelations(trajectory, relations), cli::EvaluateRelations(trajectory, local),
          cli::EvaluateRelations(odometry, relations)};
}

// A noisy-odometry row as bench/laser/laser_reference.cc `noisy` writes it (no --raw: the keyframe
// stamp rule), parsed back from its FLASER text.
struct NoisyRow {
  std::vector<CarmenLaser> lasers;
  std::vector<cli::Relation> relations;
};

absl::StatusOr<NoisyRow> MakeNoisyRow(const std::string& corrected, cli::NoiseStrength strength,
                                      uint64_t seed) {
  absl::StatusOr<std::vector<CarmenLaser>> keyframes =
      adapters::ReadLaserLinesInFileOrder(corrected);
  if (!keyframes.ok()) return keyframes.status();
  std::vector<double> log_stamps;
  for (const CarmenLaser& k : *keyframes) log_stamps.push_back(k.stamp);
  const adapters::KeyframeStamps stamps = adapters::ChooseKeyframeStamps(log_stamps);
  std::vector<cli::StampedPose> truth;
  std::vector<cli::Pose2> truth_poses;
  for (size_t i = 0; i < keyframes->size(); ++i) {
    const CarmenLaser& k = (*keyframes)[i];
    const cli::Pose2 pose{k.laser_pose.x, k.laser_pose.y, cli::NormalizeAngle(k.laser_pose.theta)};
    truth.push_back({stamps.stamps[i], pose});
    truth_poses.push_back(pose);
  }
  const cli::NoisyOdometry odometry =
      cli::GenerateNoisyOdometry(truth_poses, cli::NoiseFor(strength), seed);
  NoisyRow row;
  std::vector<CarmenLaser> lasers;
  for (size_t i = 0; i < keyframes->size(); ++i) {
    CarmenLaser line = (*keyframes)[i];
    line.stamp = stamps.stamps[i];
    const cli::Pose2& p = odometry.poses[i];
    line.laser_pose = {p.x, p.y, p.theta};
    line.odom_pose = line.laser_pose;
    adapters::CarmenRecord record;
    absl::StatusOr<bool> parsed = adapters::ParseCarmenLine(
        adapters::FormatFlaserLine(line, "noisy"), static_cast<int64_t>(i + 1), &record);
    if (!parsed.ok()) return parsed.status();
    lasers.push_back(record.laser);
  }
  row.lasers = SortedLasers(std::move(lasers), 0);
  row.relations = cli::BuildRelations(truth).relations;
  return row;
}

std::string Describe(const Scores& s) {
  return "all " + std::to_string(s.all.trans_abs.mean) + " m (" +
         std::to_string(s.all.relations_used) + " of " + std::to_string(s.all.relations) +
         " relations), local " + std::to_string(s.local.trans_abs.mean) + " m, odometry all " +
         std::to_string(s.odometry_all.trans_abs.mean) + " m";
}

TEST(LaserRealDataFloors, AcesFirstScansAgainstPublishedRelations) {
  const std::filesystem::path log = LaserData() / "aces" / "aces.clf.bz2";
  const std::filesystem::path relations_file = LaserData() / "aces" / "aces.relations";
  if (!std::filesystem::exists(log) || !std::filesystem::exists(relations_file)) {
    GTEST_SKIP() << "no " << log << " or its relations (../shared absent)";
  }
  absl::StatusOr<std::vector<CarmenLaser>> lasers = ReadLog(log.string(), 2000);
  ASSERT_TRUE(lasers.ok()) << lasers.status();
  ASSERT_EQ(lasers->size(), 2000u);
  absl::StatusOr<std::vector<cli::Relation>> relations =
      cli::ReadRelationsFile(relations_file.string());
  ASSERT_TRUE(relations.ok()) << relations.status();

  const Scores s = RunAndScore(*lasers, *relations, ls::SlamOptions{});
  std::cout << "measured: " << Describe(s) << "\n";  // to set the floors again
  SCOPED_TRACE(Describe(s));
  // The relations whose both scans are among the first 2000 (measured: 296 of 1279).
  EXPECT_GE(s.all.relations_used, 290);
  // Measured 2026-12-05: 0.0355 m (2b11249), 0.0358 m (its working tree) over all relations (the
  // full log: 0.043 m; Cartographer's published 0.0375 m). Nearly all of these relations are
  // local (the odometry is 0.030 m on them; the EKF alone, back end off, 0.036 m): this test
  // guards the raw-log path and the EKF, the noisy rows below the loop closure. (An EKF gating
  // its matches at chi2 0.05 instead of 16 fails it on rotation: 0.78 deg.)
  EXPECT_LT(s.all.trans_abs.mean, 0.054);
  // Measured: 0.44 deg.
  EXPECT_LT(s.all.rot_abs_deg.mean, 0.66);
}

// MIT Killian (issue 33, fifth part): Kummerle's relations put onto the log's regenerated stamps
// by the scan clock fitted from its odometry (bench/laser/laser_reference.cc `restamp`), the first
// 7000 of its 17480 scans: the robot leaves the start, drives about 700 m of corridors, and comes
// back into the start's corridors from scan 6288 on. Before closures tied the robot only to the
// submaps they closed on (closure_uncertainty.h), a closure 15 m back shrank every window and
// that return was never closed.
TEST(LaserRealDataFloors, MitKillianClosesItsFirstLongLoop) {
  const std::filesystem::path log =
      LaserData() / "mit-killian" / "mit-killian_from_rawlog_SYNTHETIC_TIME.clf.gz";
  const std::filesystem::path relations_file = LaserData() / "mit-killian" / "mit-killian.relations";
  if (!std::filesystem::exists(log) || !std::filesystem::exists(relations_file)) {
    GTEST_SKIP() << "no " << log << " or its relations (../shared absent)";
  }
  absl::StatusOr<std::vector<CarmenLaser>> lasers = ReadLog(log.string(), 0);
  ASSERT_TRUE(lasers.ok()) << lasers.status();
  absl::StatusOr<std::vector<cli::Relation>> published =
      cli::ReadRelationsFile(relations_file.string());
  ASSERT_TRUE(published.ok()) << published.status();
  std::vector<cli::Pose2> odometry;
  std::vector<double> stamps;
  for (const CarmenLaser& laser : *lasers) {
    odometry.push_back({laser.odom_pose.x, laser.odom_pose.y, laser.odom_pose.theta});
    stamps.push_back(laser.stamp);
  }
  absl::StatusOr<cli::ScanClockFit> clock = cli::FitScanClock(odometry, *published);
  ASSERT_TRUE(clock.ok()) << clock.status();
  int dropped = 0;
  const std::vector<cli::Relation> relations =
      cli::RestampRelations(*published, *clock, stamps, &dropped);
  EXPECT_EQ(dropped, 0);
  lasers->resize(7000);

  const Scores s = RunAndScore(*lasers, relations, ls::SlamOptions{});
  std::cout << "measured: " << Describe(s) << "\n";
  SCOPED_TRACE(Describe(s));
  // Measured 2026-12-05: 2031 of the 4677 relations have both scans among the first 7000; all
  // relations 0.218 m (odometry 26.3 m); with the windows of before (window_through_ties =
  // false) 2.52 m. Floor 1.5x.
  EXPECT_GE(s.all.relations_used, 2000);
  EXPECT_LT(s.all.trans_abs.mean, 0.33);
}

struct NoisyFloor {
  const char* name;       // the bench's row name, with '_' for '-'
  const char* corrected;  // under ../shared/data/laser
  double all_floor_m;     // all relations, translation mean
  double local_floor_m;   // relations up to 10 s apart
};

class LaserNoisyOdometryFloors : public ::testing::TestWithParam<NoisyFloor> {};

TEST_P(LaserNoisyOdometryFloors, MediumOdometryNoiseIsCorrected) {
  const NoisyFloor& floor = GetParam();
  const std::filesystem::path corrected = LaserData() / floor.corrected;
  if (!std::filesystem::exists(corrected)) {
    GTEST_SKIP() << "no " << corrected << " (../shared absent)";
  }
  absl::StatusOr<NoisyRow> row =
      MakeNoisyRow(corrected.string(), cli::NoiseStrength::kMedium, /*seed=*/1);
  ASSERT_TRUE(row.ok()) << row.status();
  ASSERT_FALSE(row->relations.empty());

  const Scores s = RunAndScore(row->lasers, row->relations, ls::SlamOptions{});
  std::cout << "measured: " << Describe(s) << "\n";
  SCOPED_TRACE(Describe(s));
  EXPECT_EQ(s.all.relations_used, s.all.relations);  // every keyframe has a pose
  EXPECT_LT(s.all.trans_abs.mean, floor.all_floor_m);
  EXPECT_LT(s.local.trans_abs.mean, floor.local_floor_m);
  // The row is a test of correction, not of good odometry: its odometry is far off.
  EXPECT_GT(s.odometry_all.trans_abs.mean, 10 * floor.all_floor_m);
}

// Measured 2026-12-05, seed 1 (all / local, m; the larger of 2b11249 and its working tree), the
// rows of bench/laser/laser_benchmark.sh: seattle-corrected-medium 0.036 / 0.021 (odometry all
// 3.86), freiburg-101-corrected-medium 0.038 / 0.031 (1.54), intel-corrected-medium 0.046 / 0.029
// (3.39), aces-corrected-medium 0.079 / 0.045 (1.43; 0.064 / 0.044 at 2b11249). Floors 1.5x.
INSTANTIATE_TEST_SUITE_P(
    MediumRows, LaserNoisyOdometryFloors,
    ::testing::Values(
        NoisyFloor{"seattle_corrected_medium", "radish-corrected/seattle-corrected.log.gz", 0.054,
                   0.032},
        NoisyFloor{"freiburg_101_corrected_medium",
                   "radish-corrected/freiburg-101-corrected.log.gz", 0.057, 0.047},
        NoisyFloor{"intel_corrected_medium", "intel/intel-corrected.log.gz", 0.069, 0.044},
        NoisyFloor{"aces_corrected_medium", "aces/aces-corrected.log.gz", 0.118, 0.068}),
    [](const ::testing::TestParamInfo<NoisyFloor>& info) { return std::string(info.param.name); });

}  // namespace
}  // namespace waymark
