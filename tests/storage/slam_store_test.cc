// The SQLite SlamStore against real files: sessions, checkpoints that append the trajectory in one
// transaction, closing, listing, cascades, reopening, a crossing store on the same file.

#include "storage/slam_store.h"

#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "gtest/gtest.h"
#include "storage/crossing_store.h"
#include "storage/migrations.h"
#include "storage/sqlite.h"
#include "tests/storage/status_testing.h"
#include "tests/storage/temp_dir.h"

namespace waymark::storage {
namespace {

using ::waymark::storage::testing::CodeOf;
using ::waymark::storage::testing::TempDir;

SlamSessionRecord MakeSession(const std::string& id, const std::string& robot) {
  SlamSessionRecord session;
  session.id = id;
  session.robot_id = robot;
  session.name = "run " + id;
  session.config = std::string("\x0a\x03\x00\x01\x02", 5);  // opaque bytes, with a NUL
  return session;
}

std::vector<TrajectoryPoseRecord> Poses(int64_t first, int count) {
  std::vector<TrajectoryPoseRecord> poses;
  for (int i = 0; i < count; ++i) {
    TrajectoryPoseRecord pose;
    pose.seq = first + i;
    pose.stamp = 100.0 + static_cast<double>(pose.seq);
    pose.x = 0.5 * static_cast<double>(pose.seq);
    pose.y = -0.25 * static_cast<double>(pose.seq);
    pose.theta = 0.01 * static_cast<double>(pose.seq);
    for (int k = 0; k < 9; ++k) pose.covariance[k] = static_cast<double>(pose.seq) + 0.1 * k;
    poses.push_back(pose);
  }
  return poses;
}

SlamCheckpoint Checkpoint(const std::string& state, int64_t scans, int64_t first_pose,
                          int new_poses) {
  SlamCheckpoint checkpoint;
  checkpoint.state = state;
  checkpoint.scans_processed = scans;
  checkpoint.map_revision = scans * 2;
  checkpoint.segments = static_cast<int32_t>(scans / 3);
  checkpoint.last_scan_stamp = 100.0 + static_cast<double>(scans);
  checkpoint.last_odometry_stamp = 100.5 + static_cast<double>(scans);
  checkpoint.new_poses = Poses(first_pose, new_poses);
  return checkpoint;
}

TEST(SlamStoreTest, CreateGetAndList) {
  TempDir dir;
  ASSERT_OK_AND_ASSIGN(auto store, OpenSqliteSlamStore(dir.File("w.db")));
  ASSERT_OK_AND_ASSIGN(SlamSessionRecord a, store->CreateSession(MakeSession("a1", "robot-1")));
  EXPECT_GT(a.created_at, 0);
  EXPECT_EQ(a.created_at, a.updated_at);
  ASSERT_OK(store->CreateSession(MakeSession("b2", "robot-2")));
  ASSERT_OK(store->CreateSession(MakeSession("c3", "robot-1")));

  ASSERT_OK_AND_ASSIGN(SlamSessionRecord got, store->GetSession("a1"));
  EXPECT_EQ(got.robot_id, "robot-1");
  EXPECT_EQ(got.name, "run a1");
  EXPECT_EQ(got.kind, "laser");
  EXPECT_EQ(got.config, std::string("\x0a\x03\x00\x01\x02", 5));
  EXPECT_EQ(got.state, SlamSessionState::kOpen);
  EXPECT_EQ(got.scans_processed, 0);
  EXPECT_TRUE(got.checkpoint.empty());
  EXPECT_EQ(got.checkpoint_at, 0);
  EXPECT_FALSE(got.last_scan_stamp.has_value());
  EXPECT_FALSE(got.last_odometry_stamp.has_value());
  EXPECT_EQ(got.trajectory_length, 0);

  ASSERT_OK_AND_ASSIGN(auto all, store->ListSessions(""));
  ASSERT_EQ(all.size(), 3u);
  ASSERT_OK_AND_ASSIGN(auto robot1, store->ListSessions("robot-1"));
  ASSERT_EQ(robot1.size(), 2u);
  EXPECT_EQ(robot1[0].id, "a1");
  EXPECT_EQ(robot1[1].id, "c3");
  ASSERT_OK_AND_ASSIGN(auto none, store->ListSessions("robot-9"));
  EXPECT_TRUE(none.empty());
  ASSERT_OK_AND_ASSIGN(int64_t open, store->CountSessions(SlamSessionState::kOpen));
  EXPECT_EQ(open, 3);
}

TEST(SlamStoreTest, Errors) {
  TempDir dir;
  ASSERT_OK_AND_ASSIGN(auto store, OpenSqliteSlamStore(dir.File("w.db")));
  ASSERT_OK(store->CreateSession(MakeSession("a1", "r")));
  EXPECT_EQ(CodeOf(store->CreateSession(MakeSession("a1", "r"))), absl::StatusCode::kAlreadyExists);
  EXPECT_EQ(CodeOf(store->CreateSession(MakeSession("", "r"))), absl::StatusCode::kInvalidArgument);
  SlamSessionRecord unknown = MakeSession("v", "r");
  unknown.kind = "sonar";  // laser and visual are the kinds
  EXPECT_EQ(CodeOf(store->CreateSession(unknown)), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf(store->GetSession("nope")), absl::StatusCode::kNotFound);
  EXPECT_EQ(CodeOf(store->LoadTrajectory("nope")), absl::StatusCode::kNotFound);
  EXPECT_EQ(CodeOf(store->WriteCheckpoint("nope", Checkpoint("s", 1, 0, 1))),
            absl::StatusCode::kNotFound);
  EXPECT_EQ(CodeOf(store->DeleteSession("nope")), absl::StatusCode::kNotFound);
  SlamCheckpoint nan = Checkpoint("s", 1, 0, 1);
  nan.new_poses[0].x = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(CodeOf(store->WriteCheckpoint("a1", nan)), absl::StatusCode::kInvalidArgument);
}

TEST(SlamStoreTest, CheckpointsAppendTheTrajectory) {
  TempDir dir;
  ASSERT_OK_AND_ASSIGN(auto store, OpenSqliteSlamStore(dir.File("w.db")));
  ASSERT_OK(store->CreateSession(MakeSession("s", "r")));
  ASSERT_OK(store->WriteCheckpoint("s", Checkpoint(std::string("state\0one", 9), 3, 0, 3)));
  ASSERT_OK(store->WriteCheckpoint("s", Checkpoint("state two", 5, 3, 2)));
  ASSERT_OK(store->WriteCheckpoint("s", Checkpoint("state three", 5, 5, 0)));  // nothing new

  ASSERT_OK_AND_ASSIGN(SlamSessionRecord session, store->GetSession("s"));
  EXPECT_EQ(session.checkpoint, "state three");
  EXPECT_GT(session.checkpoint_at, 0);
  EXPECT_EQ(session.scans_processed, 5);
  EXPECT_EQ(session.map_revision, 10);
  EXPECT_EQ(session.segments, 1);
  EXPECT_EQ(session.last_scan_stamp, 105.0);
  EXPECT_EQ(session.last_odometry_stamp, 105.5);
  EXPECT_EQ(session.trajectory_length, 5);

  ASSERT_OK_AND_ASSIGN(auto poses, store->LoadTrajectory("s"));
  ASSERT_EQ(poses.size(), 5u);
  const auto expected = Poses(0, 5);
  for (size_t i = 0; i < poses.size(); ++i) {
    EXPECT_EQ(poses[i].seq, static_cast<int64_t>(i));
    EXPECT_EQ(poses[i].stamp, expected[i].stamp);
    EXPECT_EQ(poses[i].x, expected[i].x);
    EXPECT_EQ(poses[i].y, expected[i].y);
    EXPECT_EQ(poses[i].theta, expected[i].theta);
    EXPECT_EQ(poses[i].covariance, expected[i].covariance);
  }
  // ListSessions leaves the checkpoint bytes out but counts the poses.
  ASSERT_OK_AND_ASSIGN(auto listed, store->ListSessions(""));
  ASSERT_EQ(listed.size(), 1u);
  EXPECT_TRUE(listed[0].checkpoint.empty());
  EXPECT_EQ(listed[0].trajectory_length, 5);
}

TEST(SlamStoreTest, ACheckpointWithAGapChangesNothing) {
  TempDir dir;
  ASSERT_OK_AND_ASSIGN(auto store, OpenSqliteSlamStore(dir.File("w.db")));
  ASSERT_OK(store->CreateSession(MakeSession("s", "r")));
  ASSERT_OK(store->WriteCheckpoint("s", Checkpoint("one", 2, 0, 2)));
  // Poses 3.. skip seq 2; a repeat of 0.. would duplicate: both are refused as a whole.
  EXPECT_EQ(CodeOf(store->WriteCheckpoint("s", Checkpoint("gap", 9, 3, 4))),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf(store->WriteCheckpoint("s", Checkpoint("repeat", 9, 0, 4))),
            absl::StatusCode::kInvalidArgument);
  ASSERT_OK_AND_ASSIGN(SlamSessionRecord session, store->GetSession("s"));
  EXPECT_EQ(session.checkpoint, "one");
  EXPECT_EQ(session.scans_processed, 2);
  EXPECT_EQ(session.trajectory_length, 2);
}

TEST(SlamStoreTest, CloseWritesTheFinalCheckpointAndRefusesMore) {
  TempDir dir;
  ASSERT_OK_AND_ASSIGN(auto store, OpenSqliteSlamStore(dir.File("w.db")));
  ASSERT_OK(store->CreateSession(MakeSession("s", "r")));
  ASSERT_OK(store->WriteCheckpoint("s", Checkpoint("one", 2, 0, 2)));
  ASSERT_OK(store->CloseSession("s", Checkpoint("final", 4, 2, 2)));
  ASSERT_OK_AND_ASSIGN(SlamSessionRecord session, store->GetSession("s"));
  EXPECT_EQ(session.state, SlamSessionState::kClosed);
  EXPECT_EQ(session.checkpoint, "final");
  EXPECT_EQ(session.trajectory_length, 4);
  EXPECT_EQ(CodeOf(store->WriteCheckpoint("s", Checkpoint("late", 5, 4, 1))),
            absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(CodeOf(store->CloseSession("s", Checkpoint("again", 5, 4, 0))),
            absl::StatusCode::kFailedPrecondition);
  ASSERT_OK_AND_ASSIGN(int64_t open, store->CountSessions(SlamSessionState::kOpen));
  ASSERT_OK_AND_ASSIGN(int64_t closed, store->CountSessions(SlamSessionState::kClosed));
  EXPECT_EQ(open, 0);
  EXPECT_EQ(closed, 1);
}

TEST(SlamStoreTest, DeleteCascadesToTheTrajectory) {
  TempDir dir;
  const std::string path = dir.File("w.db");
  ASSERT_OK_AND_ASSIGN(auto store, OpenSqliteSlamStore(path));
  ASSERT_OK(store->CreateSession(MakeSession("s", "r")));
  ASSERT_OK(store->CreateSession(MakeSession("t", "r")));
  ASSERT_OK(store->WriteCheckpoint("s", Checkpoint("one", 3, 0, 3)));
  ASSERT_OK(store->WriteCheckpoint("t", Checkpoint("one", 2, 0, 2)));
  ASSERT_OK_AND_ASSIGN(SlamSessionRecord deleted, store->DeleteSession("s"));
  EXPECT_EQ(deleted.id, "s");
  EXPECT_EQ(deleted.name, "run s");
  EXPECT_EQ(deleted.scans_processed, 3);
  EXPECT_EQ(deleted.trajectory_length, 3);  // the poses that went with it
  EXPECT_EQ(CodeOf(store->GetSession("s")), absl::StatusCode::kNotFound);
  EXPECT_EQ(CodeOf(store->LoadTrajectory("s")), absl::StatusCode::kNotFound);
  EXPECT_EQ(CodeOf(store->DeleteSession("s")), absl::StatusCode::kNotFound);
  ASSERT_OK_AND_ASSIGN(sqlite::Connection raw, sqlite::Connection::Open(path));
  ASSERT_OK_AND_ASSIGN(sqlite::Statement count,
                       raw.Prepare("SELECT COUNT(*) FROM slam_trajectory"));
  ASSERT_OK_AND_ASSIGN(sqlite::StepResult step, count.Step());
  ASSERT_EQ(step, sqlite::StepResult::kRow);
  EXPECT_EQ(count.ColumnInt64(0), 2);  // only t's poses remain
}

TEST(SlamStoreTest, DeleteTakesClosedSessionsAndLeavesTheOthers) {
  TempDir dir;
  ASSERT_OK_AND_ASSIGN(auto store, OpenSqliteSlamStore(dir.File("w.db")));
  ASSERT_OK(store->CreateSession(MakeSession("c", "r")));
  ASSERT_OK(store->CreateSession(MakeSession("keep", "r")));
  ASSERT_OK(store->CloseSession("c", Checkpoint("final", 4, 0, 4)));
  ASSERT_OK_AND_ASSIGN(SlamSessionRecord deleted, store->DeleteSession("c"));
  EXPECT_EQ(deleted.state, SlamSessionState::kClosed);
  EXPECT_EQ(deleted.trajectory_length, 4);
  EXPECT_TRUE(deleted.checkpoint.empty());  // rows and counters, not the engine's bytes
  ASSERT_OK_AND_ASSIGN(std::vector<SlamSessionRecord> left, store->ListSessions(""));
  ASSERT_EQ(left.size(), 1u);
  EXPECT_EQ(left[0].id, "keep");
  ASSERT_OK_AND_ASSIGN(int64_t closed, store->CountSessions(SlamSessionState::kClosed));
  EXPECT_EQ(closed, 0);
}

TEST(SlamStoreTest, TheTrajectoryForeignKeyCascades) {
  ASSERT_OK_AND_ASSIGN(sqlite::Connection connection, sqlite::Connection::Open(":memory:"));
  ASSERT_OK(MigrateSchema(connection));
  ASSERT_OK_AND_ASSIGN(sqlite::Statement fks,
                       connection.Prepare("SELECT \"table\", on_delete FROM "
                                          "pragma_foreign_key_list('slam_trajectory')"));
  ASSERT_OK_AND_ASSIGN(sqlite::StepResult step, fks.Step());
  ASSERT_EQ(step, sqlite::StepResult::kRow);
  EXPECT_EQ(fks.ColumnText(0), "slam_session");
  EXPECT_EQ(fks.ColumnText(1), "CASCADE");
}

TEST(SlamStoreTest, SurvivesReopenAndSharesTheFileWithTheCrossingStore) {
  TempDir dir;
  const std::string path = dir.File("sub/w.db");
  {
    ASSERT_OK_AND_ASSIGN(auto crossings, OpenSqliteCrossingStore(path));
    ASSERT_OK_AND_ASSIGN(auto store, OpenSqliteSlamStore(path));
    ASSERT_OK(crossings->CreateDatabase("city", "{}"));
    ASSERT_OK(store->CreateSession(MakeSession("s", "r")));
    ASSERT_OK(store->WriteCheckpoint("s", Checkpoint("one", 3, 0, 3)));
  }
  ASSERT_OK_AND_ASSIGN(auto store, OpenSqliteSlamStore(path));
  ASSERT_OK_AND_ASSIGN(SlamSessionRecord session, store->GetSession("s"));
  EXPECT_EQ(session.checkpoint, "one");
  EXPECT_EQ(session.scans_processed, 3);
  ASSERT_OK_AND_ASSIGN(auto poses, store->LoadTrajectory("s"));
  EXPECT_EQ(poses.size(), 3u);
  ASSERT_OK_AND_ASSIGN(auto crossings, OpenSqliteCrossingStore(path));
  ASSERT_OK_AND_ASSIGN(auto dbs, crossings->ListDatabases());
  EXPECT_EQ(dbs.size(), 1u);
}

}  // namespace
}  // namespace waymark::storage
