// Visual sessions in the SlamStore: the kind is accepted and 3-D trajectory poses round-trip with
// their z and quaternion while laser rows keep NULL there, on both backends (a SQLite file, a
// PostgreSQL database); and a SQLite v3 file (laser sessions only, schema v4 added visual ones)
// migrates with its sessions and trajectories intact and its cascade still working.

#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "gtest/gtest.h"
#include "storage/migrations.h"
#include "storage/open_stores.h"
#include "storage/slam_store.h"
#include "storage/sqlite.h"
#include "tests/storage/status_testing.h"
#include "tests/storage/store_backend.h"
#include "tests/storage/temp_dir.h"

namespace waymark::storage {
namespace {

using sqlite::Connection;
using sqlite::Statement;
using ::waymark::storage::testing::Backend;
using ::waymark::storage::testing::CodeOf;
using ::waymark::storage::testing::TempDir;
using ::waymark::storage::testing::TestDatabase;

SlamSessionRecord MakeSession(const std::string& id, const std::string& kind) {
  SlamSessionRecord session;
  session.id = id;
  session.robot_id = "r";
  session.kind = kind;
  session.config = "cfg";
  return session;
}

TrajectoryPoseRecord Pose3(int64_t seq) {
  TrajectoryPoseRecord pose;
  pose.seq = seq;
  pose.stamp = 10.0 + static_cast<double>(seq);
  pose.x = 0.1 * static_cast<double>(seq);
  pose.y = -0.2;
  pose.pose3 = Pose3Extra{1.5, 0.0, 0.6, 0.0, 0.8};
  return pose;
}

TrajectoryPoseRecord Pose2(int64_t seq) {
  TrajectoryPoseRecord pose;
  pose.seq = seq;
  pose.stamp = 20.0 + static_cast<double>(seq);
  pose.x = 1;
  pose.y = 2;
  pose.theta = 0.3;
  pose.covariance[0] = 0.01;
  return pose;
}

class VisualSlamStoreTest : public ::testing::TestWithParam<Backend> {
 protected:
  VisualSlamStoreTest() : database_(GetParam(), "v.db") {}

  void SetUp() override { WAYMARK_SKIP_WITHOUT(database_); }

  TestDatabase database_;
};

INSTANTIATE_TEST_SUITE_P(Backends, VisualSlamStoreTest, testing::kBothBackends,
                         testing::BackendName);

TEST_P(VisualSlamStoreTest, ThreeDimensionalPosesRoundTripBesideLaserRows) {
  ASSERT_OK_AND_ASSIGN(auto store, OpenSlamStore(database_.db()));
  ASSERT_OK_AND_ASSIGN(SlamSessionRecord visual, store->CreateSession(MakeSession("v", "visual")));
  EXPECT_EQ(visual.kind, "visual");
  ASSERT_OK(store->CreateSession(MakeSession("l", "laser")));

  SlamCheckpoint checkpoint;
  checkpoint.state = "vo";
  checkpoint.scans_processed = 2;
  checkpoint.last_scan_stamp = 11.0;
  checkpoint.new_poses = {Pose3(0), Pose3(1)};
  ASSERT_OK(store->WriteCheckpoint("v", checkpoint));
  SlamCheckpoint laser;
  laser.state = "ekf";
  laser.scans_processed = 1;
  laser.new_poses = {Pose2(0)};
  ASSERT_OK(store->WriteCheckpoint("l", laser));

  ASSERT_OK_AND_ASSIGN(std::vector<TrajectoryPoseRecord> poses, store->LoadTrajectory("v"));
  ASSERT_EQ(poses.size(), 2u);
  ASSERT_TRUE(poses[1].pose3.has_value());
  EXPECT_DOUBLE_EQ(poses[1].x, 0.1);
  EXPECT_DOUBLE_EQ(poses[1].pose3->z, 1.5);
  EXPECT_DOUBLE_EQ(poses[1].pose3->qy, 0.6);
  EXPECT_DOUBLE_EQ(poses[1].pose3->qw, 0.8);
  ASSERT_OK_AND_ASSIGN(std::vector<TrajectoryPoseRecord> laser_poses, store->LoadTrajectory("l"));
  ASSERT_EQ(laser_poses.size(), 1u);
  EXPECT_FALSE(laser_poses[0].pose3.has_value());
  EXPECT_DOUBLE_EQ(laser_poses[0].theta, 0.3);
  ASSERT_OK_AND_ASSIGN(SlamSessionRecord got, store->GetSession("v"));
  EXPECT_EQ(got.kind, "visual");
  EXPECT_EQ(got.trajectory_length, 2);

  ASSERT_OK_AND_ASSIGN(int64_t null_z,
                       database_.CountRows("slam_trajectory", "z IS NULL AND qw IS NULL"));
  EXPECT_EQ(null_z, 1);  // the laser row only

  SlamCheckpoint nan = checkpoint;
  nan.new_poses = {Pose3(2)};
  nan.new_poses[0].pose3->qx = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(CodeOf(store->WriteCheckpoint("v", nan)), absl::StatusCode::kInvalidArgument);
}

// SQLite only: PostgreSQL support starts at the schema that already has visual sessions.
TEST(VisualSlamStoreSqliteTest, VersionThreeFileMigratesWithItsLaserSessions) {
  TempDir dir;
  const std::string path = dir.File("old.db");
  {
    // The file as a v3 build left it: laser rows in the v2 tables.
    ASSERT_OK_AND_ASSIGN(Connection connection, Connection::Open(path));
    std::vector<absl::string_view> v3(SchemaMigrations().begin(), SchemaMigrations().begin() + 3);
    ASSERT_OK(ApplyMigrations(connection, v3));
    ASSERT_OK(connection.Exec(
        "INSERT INTO slam_session (id, robot_id, kind, config, state, created_at, updated_at, "
        "scans_processed, checkpoint, last_scan_stamp) "
        "VALUES ('old', 'r', 'laser', x'01', 'open', 1, 2, 7, x'0203', 5.5)"));
    ASSERT_OK(connection.Exec(
        "INSERT INTO slam_trajectory VALUES ('old', 0, 5.0, 1.0, 2.0, 0.5, zeroblob(72)), "
        "('old', 1, 5.5, 1.5, 2.5, 0.6, zeroblob(72))"));
  }
  ASSERT_OK_AND_ASSIGN(auto store, OpenSqliteSlamStore(path));
  ASSERT_OK_AND_ASSIGN(SlamSessionRecord old, store->GetSession("old"));
  EXPECT_EQ(old.kind, "laser");
  EXPECT_EQ(old.scans_processed, 7);
  EXPECT_EQ(old.checkpoint, std::string("\x02\x03"));
  ASSERT_TRUE(old.last_scan_stamp.has_value());
  EXPECT_DOUBLE_EQ(*old.last_scan_stamp, 5.5);
  EXPECT_EQ(old.trajectory_length, 2);
  ASSERT_OK_AND_ASSIGN(std::vector<TrajectoryPoseRecord> poses, store->LoadTrajectory("old"));
  ASSERT_EQ(poses.size(), 2u);
  EXPECT_DOUBLE_EQ(poses[1].theta, 0.6);
  EXPECT_FALSE(poses[1].pose3.has_value());

  ASSERT_OK(store->CreateSession(MakeSession("new", "visual")));  // the new CHECK allows it
  // The rebuilt trajectory table still cascades from the (renamed) session table.
  ASSERT_OK(store->DeleteSession("old"));
  EXPECT_EQ(CodeOf(store->LoadTrajectory("old")), absl::StatusCode::kNotFound);
  ASSERT_OK_AND_ASSIGN(Connection connection, Connection::Open(path));
  absl::StatusOr<Statement> count = connection.Prepare("SELECT COUNT(*) FROM slam_trajectory");
  ASSERT_OK(count.status());
  ASSERT_OK(count->Step().status());
  EXPECT_EQ(count->ColumnInt64(0), 0);
  ASSERT_OK_AND_ASSIGN(int version, ReadSchemaVersion(connection));
  EXPECT_EQ(version, CurrentSchemaVersion());
}

}  // namespace
}  // namespace waymark::storage
