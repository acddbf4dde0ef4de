// The whole engine on simulated scans of known rooms: a robot driving a known square room
// recovers it; bad input is rejected without touching the session; checkpoints resume exactly.

#include "server/laser_slam/laser_slam.h"

#include <cmath>
#include <limits>
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

  // The map: the four walls, each once, at the right place. Each segment is moved by the back
  // end's correction at the scan that last saw it, which carries local matching's error (a few
  // mrad: up to 3.1 cm at a wall end 3 m away; 3 cm before local matching).
  const std::vector<MapSegment> map = run.slam->Map();
  EXPECT_EQ(map.size(), 4u);
  for (const MapSegment& s : map) {
    // Map frame -> world: compose with the first true pose.
    const Pose2 a = Compose(steps[0].truth, Compose(s.frame, Pose2{s.left, 0, 0}));
    const Pose2 b = Compose(steps[0].truth, Compose(s.frame, Pose2{s.right, 0, 0}));
    const bool vertical = std::abs(a.x - b.x) < std::abs(a.y - b.y);
    if (vertical) {
      EXPECT_NEAR(std::abs(a.x), 3.0, 0.035);
      EXPECT_NEAR(std::abs(b.x), 3.0, 0.035);
    } else {
      EXPECT_NEAR(std::abs(a.y), 2.5, 0.035);
      EXPECT_NEAR(std::abs(b.y), 2.5, 0.035);
    }
  }
}

}  // namespace
}  // namespace waymark::laser_slam

namespace waymark::laser_slam {
namespace {

std::vector<Step> ShortDrive() {
  return SquareDrive(testing::Box(-3.0, -2.5, 3.0, 2.5), 2.0, 1, 0.01, 0.02, 9);
}

TEST(LaserSlamTest, BadInputIsRejectedAndLeavesTheSessionUnchanged) {
  const std::vector<Step> steps = ShortDrive();
  LaserSlam slam{SlamOptions{}};
  for (int i = 0; i < 5; ++i) {
    ASSERT_TRUE(slam.AddOdometry({steps[i].scan.stamp, steps[i].odometry}).ok());
    ASSERT_TRUE(slam.AddScan(steps[i].scan).ok());
  }
  const PoseEstimate before = slam.CurrentPose();
  const std::size_t segments = slam.Map().size();

  LaserScan old = steps[4].scan;  // duplicate stamp
  EXPECT_EQ(slam.AddScan(old).status().code(), absl::StatusCode::kInvalidArgument);
  old.stamp = steps[2].scan.stamp;  // out of order
  EXPECT_EQ(slam.AddScan(old).status().code(), absl::StatusCode::kInvalidArgument);
  LaserScan short_scan = steps[5].scan;
  short_scan.ranges.pop_back();  // disagrees with its geometry
  EXPECT_EQ(slam.AddScan(short_scan).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(slam.AddOdometry({steps[1].scan.stamp, steps[1].odometry}).code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(slam.AddOdometry({std::nan(""), steps[1].odometry}).code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(slam.scans_processed(), 5u);
  EXPECT_EQ(slam.CurrentPose().pose.x, before.pose.x);
  EXPECT_EQ(slam.Map().size(), segments);

  // NaN, infinite and negative ranges are no-returns: the scan is processed.
  LaserScan holes = steps[5].scan;
  for (std::size_t i = 0; i < holes.ranges.size(); i += 7) holes.ranges[i] = std::nanf("");
  holes.ranges[3] = -1.0f;
  holes.ranges[4] = std::numeric_limits<float>::infinity();
  ASSERT_TRUE(slam.AddOdometry({holes.stamp, steps[5].odometry}).ok());
  EXPECT_TRUE(slam.AddScan(holes).ok());
  EXPECT_EQ(slam.scans_processed(), 6u);
}

// Numbers no robot measures are refused at the engine's boundary, and a jump of the odometry is
// taken for a reset of the base's counters: every answer stays finite (a 1e300 odometry used to
// be accepted and fill the pose and covariance with inf and NaN).
TEST(LaserSlamTest, OutOfRangeNumbersAreRefusedAndAnOdometryJumpIsAReset) {
  const std::vector<Step> steps = ShortDrive();
  LaserSlam slam{SlamOptions{}};
  for (int i = 0; i < 5; ++i) {
    ASSERT_TRUE(slam.AddOdometry({steps[i].scan.stamp, steps[i].odometry}).ok());
    ASSERT_TRUE(slam.AddScan(steps[i].scan).ok());
  }
  const double t = steps[5].scan.stamp;
  for (const Pose2& absurd : {Pose2{1e300, 1e300, 0}, Pose2{0, -2e6, 0}, Pose2{0, 0, 1e5}}) {
    EXPECT_EQ(slam.AddOdometry({t, absurd}).code(), absl::StatusCode::kInvalidArgument);
  }
  EXPECT_EQ(slam.AddOdometry({1e300, steps[5].odometry}).code(),
            absl::StatusCode::kInvalidArgument);
  LaserScan far_future = steps[5].scan;
  far_future.stamp = 1e300;
  EXPECT_EQ(slam.AddScan(far_future).status().code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(slam.scans_processed(), 5u);

  // The base's odometry jumps 1000 km (within the bounds, beyond any motion between two scans).
  Pose2 jumped = steps[5].odometry;
  jumped.x += 999000;
  ASSERT_TRUE(slam.AddOdometry({t, jumped}).ok());
  const PoseEstimate before = slam.CurrentPose();
  absl::StatusOr<ScanUpdate> reset = slam.AddScan(steps[5].scan);
  ASSERT_TRUE(reset.ok()) << reset.status();
  EXPECT_TRUE(reset->odometry_reset);
  EXPECT_TRUE(FinitePose(reset->pose.pose) && reset->pose.covariance.allFinite());
  EXPECT_LT(std::hypot(reset->pose.pose.x - before.pose.x, reset->pose.pose.y - before.pose.y),
            0.5);  // no motion applied, only the scan's correction
  EXPECT_LT(reset->pose.covariance.trace(), 1.0);
  // Driving on from the new odometry origin works as before.
  for (int i = 6; i < static_cast<int>(steps.size()) && i < 10; ++i) {
    Pose2 odometry = steps[i].odometry;
    odometry.x += 999000;
    ASSERT_TRUE(slam.AddOdometry({steps[i].scan.stamp, odometry}).ok());
    absl::StatusOr<ScanUpdate> update = slam.AddScan(steps[i].scan);
    ASSERT_TRUE(update.ok()) << update.status();
    EXPECT_FALSE(update->odometry_reset);
    EXPECT_TRUE(FinitePose(update->pose.pose) && update->pose.covariance.allFinite());
  }
}

TEST(LaserSlamTest, CheckpointResumesExactly) {
  const std::vector<Step> steps = ShortDrive();
  const SlamOptions options;
  LaserSlam uninterrupted(options);
  LaserSlam first_half(options);
  const std::size_t half = steps.size() / 2;
  for (std::size_t i = 0; i < steps.size(); ++i) {
    ASSERT_TRUE(uninterrupted.AddOdometry({steps[i].scan.stamp, steps[i].odometry}).ok());
    ASSERT_TRUE(uninterrupted.AddScan(steps[i].scan).ok());
    if (i < half) {
      ASSERT_TRUE(first_half.AddOdometry({steps[i].scan.stamp, steps[i].odometry}).ok());
      ASSERT_TRUE(first_half.AddScan(steps[i].scan).ok());
    }
  }
  absl::StatusOr<std::unique_ptr<LaserSlam>> resumed =
      LaserSlam::FromCheckpoint(options, first_half.SerializeState(), first_half.LocalTrajectory());
  ASSERT_TRUE(resumed.ok()) << resumed.status();
  EXPECT_EQ((*resumed)->scans_processed(), half);
  for (std::size_t i = half; i < steps.size(); ++i) {
    ASSERT_TRUE((*resumed)->AddOdometry({steps[i].scan.stamp, steps[i].odometry}).ok());
    ASSERT_TRUE((*resumed)->AddScan(steps[i].scan).ok());
  }
  // Bit for bit (the journal's replay relies on it): the covariance is kept exactly symmetric,
  // so its lower triangle, which the checkpoint holds, is all of it.
  const PoseEstimate a = uninterrupted.CurrentPose(), b = (*resumed)->CurrentPose();
  EXPECT_EQ(a.pose.x, b.pose.x);
  EXPECT_EQ(a.pose.y, b.pose.y);
  EXPECT_EQ(a.pose.theta, b.pose.theta);
  EXPECT_EQ((a.covariance - b.covariance).cwiseAbs().maxCoeff(), 0.0);
  EXPECT_EQ(uninterrupted.Map().size(), (*resumed)->Map().size());
  EXPECT_EQ(uninterrupted.Trajectory().size(), (*resumed)->Trajectory().size());
  EXPECT_EQ(uninterrupted.map_revision(), (*resumed)->map_revision());
  // All of it: every segment, the whole covariance and the pose graph.
  EXPECT_TRUE(uninterrupted.SerializeState() == (*resumed)->SerializeState());

  // Damaged bytes are refused, never half-loaded.
  std::string state = first_half.SerializeState();
  EXPECT_EQ(LaserSlam::FromCheckpoint(options, state.substr(0, state.size() / 2), {})
                .status()
                .code(),
            absl::StatusCode::kDataLoss);
  state[0] = 'X';
  EXPECT_EQ(LaserSlam::FromCheckpoint(options, state, {}).status().code(),
            absl::StatusCode::kDataLoss);
}

// A session resumed from its checkpoint after every single scan ends exactly where the
// uninterrupted one does, segments, covariance and pose graph included: nothing the next scan
// uses is left out of a checkpoint. (A new segment's block of the covariance was not exactly
// symmetric and the checkpoint keeps the lower triangle: with loop closure on, Intel's
// trajectories ended 0.06 m apart after resumes every 1000 scans.)
TEST(LaserSlamTest, ResumingAfterEveryScanChangesNothing) {
  // A room with four pillars: walls come into view and out of it all the time, so segments are
  // added (and their covariance blocks built) throughout.
  std::vector<Wall> walls = testing::Box(-4.0, -3.5, 4.0, 3.5);
  for (const auto& [x, y] : {std::pair{-2.2, -2.2}, {1.9, -2.1}, {2.1, 1.8}, {-2.0, 2.0}}) {
    const std::vector<Wall> pillar = testing::Box(x - 0.2, y - 0.2, x + 0.2, y + 0.2);
    walls.insert(walls.end(), pillar.begin(), pillar.end());
  }
  const std::vector<Step> steps = SquareDrive(walls, 2.5, 2, 0.01, 0.02, 7);
  const SlamOptions options;  // loop closure on, in AddScan (mapping.threads = 0)
  LaserSlam uninterrupted(options);
  auto resumed = std::make_unique<LaserSlam>(options);
  for (const Step& step : steps) {
    for (LaserSlam* slam : {&uninterrupted, resumed.get()}) {
      ASSERT_TRUE(slam->AddOdometry({step.scan.stamp, step.odometry}).ok());
      ASSERT_TRUE(slam->AddScan(step.scan).ok());
    }
    absl::StatusOr<std::unique_ptr<LaserSlam>> next = LaserSlam::FromCheckpoint(
        options, resumed->SerializeState(), resumed->LocalTrajectory());
    ASSERT_TRUE(next.ok()) << next.status();
    resumed = *std::move(next);
  }
  EXPECT_TRUE(uninterrupted.SerializeState() == resumed->SerializeState());
  const std::vector<PoseEstimate> a = uninterrupted.Trajectory(), b = resumed->Trajectory();
  ASSERT_EQ(a.size(), b.size());
  for (size_t i = 0; i < a.size(); ++i) {
    ASSERT_EQ(a[i].pose.x, b[i].pose.x) << "pose " << i;
    ASSERT_EQ(a[i].pose.y, b[i].pose.y) << "pose " << i;
    ASSERT_EQ(a[i].pose.theta, b[i].pose.theta) << "pose " << i;
  }
}

// A checkpoint's robot pose beyond any map, or a stamp that is no time, is corrupt: a robot at
// 1e300 m resumed, and its next scan reached the loop search as an infinite point (make fuzz).
TEST(LaserSlamTest, ACheckpointWithAPoseBeyondAnyMapIsRefused) {
  const SlamOptions options;
  const std::string bytes = LaserSlam(options).SerializeState();
  // A new session: the magic and version (4 bytes each), have_scan (1), the last scan's stamp (8),
  // the odometry at the last update (3 x 8), revision, scans and the next segment id (8 each),
  // no odometry readings (a count of 4 bytes), then the robot's pose.
  constexpr size_t kStamp = 9;
  constexpr size_t kRobotX = kStamp + 8 + 3 * 8 + 3 * 8 + 4;
  const auto resume_with = [&](size_t at, double value) {
    std::string changed = bytes;
    changed.replace(at, sizeof(value), reinterpret_cast<const char*>(&value), sizeof(value));
    return LaserSlam::FromCheckpoint(options, changed, {}).status().code();
  };
  EXPECT_EQ(resume_with(kRobotX, 1e300), absl::StatusCode::kDataLoss);
  EXPECT_EQ(resume_with(kRobotX, std::nan("")), absl::StatusCode::kDataLoss);
  EXPECT_EQ(resume_with(kStamp, std::numeric_limits<double>::infinity()),
            absl::StatusCode::kDataLoss);
  // The offsets are right: plausible values there load.
  EXPECT_EQ(resume_with(kRobotX, 3.0), absl::StatusCode::kOk);
  EXPECT_EQ(resume_with(kStamp, 12.5), absl::StatusCode::kOk);
}

// The map's self-check of the session's graph: two laps of a room agree with each other; a
// second check with nothing moved casts no submap again (the kept checker), a session without a
// back end has none.
TEST(LaserSlamTest, TheMapChecksItselfAndRechecksOnlyWhatMoved) {
  const std::vector<Step> steps =
      SquareDrive(testing::Box(-3.0, -2.5, 3.0, 2.5), 2.0, 2, 0.01, 0.02, 7);
  Replayed run = Replay(steps, SlamOptions());
  run.slam->FlushBackend();
  absl::StatusOr<MapConsistencyReport> first = run.slam->CheckMap();
  ASSERT_TRUE(first.ok()) << first.status();
  EXPECT_TRUE(first->consistent) << first->verdict;
  EXPECT_EQ(first->nodes, run.slam->backend()->Stats().nodes);
  const int submap_nodes = SlamOptions().mapping.submap_nodes;
  EXPECT_EQ(first->submaps, (first->nodes + submap_nodes - 1) / submap_nodes);
  EXPECT_GE(first->submaps, 3);
  EXPECT_GT(first->confirmed, 0);  // the laps' walls were compared, and agree
  EXPECT_EQ(first->submaps_cast, first->submaps);

  absl::StatusOr<MapConsistencyReport> second = run.slam->CheckMap();
  ASSERT_TRUE(second.ok()) << second.status();
  EXPECT_EQ(second->submaps_cast, 0);
  EXPECT_EQ(second->verdict, first->verdict);

  SlamOptions paper_alone;
  paper_alone.mapping.enabled = false;
  LaserSlam no_backend(paper_alone);
  EXPECT_EQ(no_backend.CheckMap().status().code(), absl::StatusCode::kFailedPrecondition);
}

}  // namespace
}  // namespace waymark::laser_slam
