// The SlamStore on both backends (a SQLite file, a PostgreSQL database): sessions, checkpoints
// that append the trajectory in one transaction, closing, listing, cascades, reopening, a crossing
// store on the same database.

#include "storage/slam_store.h"

#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "gtest/gtest.h"
#include "storage/crossing_store.h"
#include "storage/open_stores.h"
#include "tests/storage/status_testing.h"
#include "tests/storage/store_backend.h"

namespace waymark::storage {
namespace {

using ::waymark::storage::testing::Backend;
using ::waymark::storage::testing::CodeOf;
using ::waymark::storage::testing::TestDatabase;

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

// The suite runs on both backends (store_backend.h).
class SlamStoreTest : public ::testing::TestWithParam<Backend> {
 protected:
  // On SQLite the nested path also checks that the parent directory is created.
  SlamStoreTest() : database_(GetParam(), "sub/w.db") {}

  void SetUp() override {
    WAYMARK_SKIP_WITHOUT(database_);
    ASSERT_OK_AND_ASSIGN(store_, OpenSlamStore(database_.db()));
  }

  TestDatabase database_;
  std::unique_ptr<SlamStore> store_;
};

INSTANTIATE_TEST_SUITE_P(Backends, SlamStoreTest, testing::kBothBackends, testing::BackendName);

TEST_P(SlamStoreTest, CreateGetAndList) {
  ASSERT_OK_AND_ASSIGN(SlamSessionRecord a, store_->CreateSession(MakeSession("a1", "robot-1")));
  EXPECT_GT(a.created_at, 0);
  EXPECT_EQ(a.created_at, a.updated_at);
  ASSERT_OK(store_->CreateSession(MakeSession("b2", "robot-2")));
  ASSERT_OK(store_->CreateSession(MakeSession("c3", "robot-1")));

  ASSERT_OK_AND_ASSIGN(SlamSessionRecord got, store_->GetSession("a1"));
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

  ASSERT_OK_AND_ASSIGN(auto all, store_->ListSessions(""));
  ASSERT_EQ(all.size(), 3u);
  ASSERT_OK_AND_ASSIGN(auto robot1, store_->ListSessions("robot-1"));
  ASSERT_EQ(robot1.size(), 2u);
  EXPECT_EQ(robot1[0].id, "a1");
  EXPECT_EQ(robot1[1].id, "c3");
  ASSERT_OK_AND_ASSIGN(auto none, store_->ListSessions("robot-9"));
  EXPECT_TRUE(none.empty());
  ASSERT_OK_AND_ASSIGN(int64_t open, store_->CountSessions(SlamSessionState::kOpen));
  EXPECT_EQ(open, 3);
}

TEST_P(SlamStoreTest, Errors) {
  ASSERT_OK(store_->CreateSession(MakeSession("a1", "r")));
  EXPECT_EQ(CodeOf(store_->CreateSession(MakeSession("a1", "r"))),
            absl::StatusCode::kAlreadyExists);
  EXPECT_EQ(CodeOf(store_->CreateSession(MakeSession("", "r"))),
            absl::StatusCode::kInvalidArgument);
  SlamSessionRecord unknown = MakeSession("v", "r");
  unknown.kind = "sonar";  // laser and visual are the kinds
  EXPECT_EQ(CodeOf(store_->CreateSession(unknown)), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf(store_->GetSession("nope")), absl::StatusCode::kNotFound);
  EXPECT_EQ(CodeOf(store_->LoadTrajectory("nope")), absl::StatusCode::kNotFound);
  EXPECT_EQ(CodeOf(store_->WriteCheckpoint("nope", Checkpoint("s", 1, 0, 1))),
            absl::StatusCode::kNotFound);
  EXPECT_EQ(CodeOf(store_->DeleteSession("nope")), absl::StatusCode::kNotFound);
  SlamCheckpoint nan = Checkpoint("s", 1, 0, 1);
  nan.new_poses[0].x = std::numeric_limits<double>::quiet_NaN();
  EXPECT_EQ(CodeOf(store_->WriteCheckpoint("a1", nan)), absl::StatusCode::kInvalidArgument);
}

TEST_P(SlamStoreTest, CheckpointsAppendTheTrajectory) {
  ASSERT_OK(store_->CreateSession(MakeSession("s", "r")));
  ASSERT_OK(store_->WriteCheckpoint("s", Checkpoint(std::string("state\0one", 9), 3, 0, 3)));
  ASSERT_OK(store_->WriteCheckpoint("s", Checkpoint("state two", 5, 3, 2)));
  ASSERT_OK(store_->WriteCheckpoint("s", Checkpoint("state three", 5, 5, 0)));  // nothing new

  ASSERT_OK_AND_ASSIGN(SlamSessionRecord session, store_->GetSession("s"));
  EXPECT_EQ(session.checkpoint, "state three");
  EXPECT_GT(session.checkpoint_at, 0);
  EXPECT_EQ(session.scans_processed, 5);
  EXPECT_EQ(session.map_revision, 10);
  EXPECT_EQ(session.segments, 1);
  EXPECT_EQ(session.last_scan_stamp, 105.0);
  EXPECT_EQ(session.last_odometry_stamp, 105.5);
  EXPECT_EQ(session.trajectory_length, 5);

  ASSERT_OK_AND_ASSIGN(auto poses, store_->LoadTrajectory("s"));
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
  ASSERT_OK_AND_ASSIGN(auto listed, store_->ListSessions(""));
  ASSERT_EQ(listed.size(), 1u);
  EXPECT_TRUE(listed[0].checkpoint.empty());
  EXPECT_EQ(listed[0].trajectory_length, 5);
}

TEST_P(SlamStoreTest, ACheckpointWithAGapChangesNothing) {
  ASSERT_OK(store_->CreateSession(MakeSession("s", "r")));
  ASSERT_OK(store_->WriteCheckpoint("s", Checkpoint("one", 2, 0, 2)));
  // Poses 3.. skip seq 2; a repeat of 0.. would duplicate: both are refused as a whole.
  EXPECT_EQ(CodeOf(store_->WriteCheckpoint("s", Checkpoint("gap", 9, 3, 4))),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf(store_->WriteCheckpoint("s", Checkpoint("repeat", 9, 0, 4))),
            absl::StatusCode::kInvalidArgument);
  ASSERT_OK_AND_ASSIGN(SlamSessionRecord session, store_->GetSession("s"));
  EXPECT_EQ(session.checkpoint, "one");
  EXPECT_EQ(session.scans_processed, 2);
  EXPECT_EQ(session.trajectory_length, 2);
}

TEST_P(SlamStoreTest, CloseWritesTheFinalCheckpointAndRefusesMore) {
  ASSERT_OK(store_->CreateSession(MakeSession("s", "r")));
  ASSERT_OK(store_->WriteCheckpoint("s", Checkpoint("one", 2, 0, 2)));
  ASSERT_OK(store_->CloseSession("s", Checkpoint("final", 4, 2, 2)));
  ASSERT_OK_AND_ASSIGN(SlamSessionRecord session, store_->GetSession("s"));
  EXPECT_EQ(session.state, SlamSessionState::kClosed);
  EXPECT_EQ(session.checkpoint, "final");
  EXPECT_EQ(session.trajectory_length, 4);
  EXPECT_EQ(CodeOf(store_->WriteCheckpoint("s", Checkpoint("late", 5, 4, 1))),
            absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(CodeOf(store_->CloseSession("s", Checkpoint("again", 5, 4, 0))),
            absl::StatusCode::kFailedPrecondition);
  ASSERT_OK_AND_ASSIGN(int64_t open, store_->CountSessions(SlamSessionState::kOpen));
  ASSERT_OK_AND_ASSIGN(int64_t closed, store_->CountSessions(SlamSessionState::kClosed));
  EXPECT_EQ(open, 0);
  EXPECT_EQ(closed, 1);
}

TEST_P(SlamStoreTest, TheClosingCheckpointKeepsTheMapCheckThatListsShow) {
  ASSERT_OK(store_->CreateSession(MakeSession("s", "r")));
  ASSERT_OK(store_->CreateSession(MakeSession("t", "r")));
  ASSERT_OK(store_->WriteCheckpoint("s", Checkpoint("one", 2, 0, 2)));
  ASSERT_OK_AND_ASSIGN(SlamSessionRecord open, store_->GetSession("s"));
  EXPECT_TRUE(open.map_check.empty());  // NULL: an open session has none
  SlamCheckpoint final_checkpoint = Checkpoint("final", 4, 2, 2);
  final_checkpoint.map_check = std::string("\x08\x01\x00verdict", 10);  // opaque, with a NUL
  ASSERT_OK(store_->CloseSession("s", final_checkpoint));
  ASSERT_OK(store_->CloseSession("t", Checkpoint("final", 1, 0, 1)));  // nothing to check
  ASSERT_OK_AND_ASSIGN(SlamSessionRecord closed, store_->GetSession("s"));
  EXPECT_EQ(closed.map_check, final_checkpoint.map_check);
  ASSERT_OK_AND_ASSIGN(auto listed, store_->ListSessions("r"));  // without checkpoint bytes
  ASSERT_EQ(listed.size(), 2u);
  EXPECT_EQ(listed[0].map_check, final_checkpoint.map_check);
  EXPECT_TRUE(listed[0].checkpoint.empty());
  EXPECT_TRUE(listed[1].map_check.empty());
}

TEST_P(SlamStoreTest, DeleteCascadesToTheTrajectory) {
  ASSERT_OK(store_->CreateSession(MakeSession("s", "r")));
  ASSERT_OK(store_->CreateSession(MakeSession("t", "r")));
  ASSERT_OK(store_->WriteCheckpoint("s", Checkpoint("one", 3, 0, 3)));
  ASSERT_OK(store_->WriteCheckpoint("t", Checkpoint("one", 2, 0, 2)));
  ASSERT_OK_AND_ASSIGN(SlamSessionRecord deleted, store_->DeleteSession("s"));
  EXPECT_EQ(deleted.id, "s");
  EXPECT_EQ(deleted.name, "run s");
  EXPECT_EQ(deleted.scans_processed, 3);
  EXPECT_EQ(deleted.trajectory_length, 3);  // the poses that went with it
  EXPECT_EQ(CodeOf(store_->GetSession("s")), absl::StatusCode::kNotFound);
  EXPECT_EQ(CodeOf(store_->LoadTrajectory("s")), absl::StatusCode::kNotFound);
  EXPECT_EQ(CodeOf(store_->DeleteSession("s")), absl::StatusCode::kNotFound);
  ASSERT_OK_AND_ASSIGN(int64_t count, database_.CountRows("slam_trajectory"));
  EXPECT_EQ(count, 2);  // only t's poses remain
}

TEST_P(SlamStoreTest, DeleteTakesClosedSessionsAndLeavesTheOthers) {
  ASSERT_OK(store_->CreateSession(MakeSession("c", "r")));
  ASSERT_OK(store_->CreateSession(MakeSession("keep", "r")));
  ASSERT_OK(store_->CloseSession("c", Checkpoint("final", 4, 0, 4)));
  ASSERT_OK_AND_ASSIGN(SlamSessionRecord deleted, store_->DeleteSession("c"));
  EXPECT_EQ(deleted.state, SlamSessionState::kClosed);
  EXPECT_EQ(deleted.trajectory_length, 4);
  EXPECT_TRUE(deleted.checkpoint.empty());  // rows and counters, not the engine's bytes
  ASSERT_OK_AND_ASSIGN(std::vector<SlamSessionRecord> left, store_->ListSessions(""));
  ASSERT_EQ(left.size(), 1u);
  EXPECT_EQ(left[0].id, "keep");
  ASSERT_OK_AND_ASSIGN(int64_t closed, store_->CountSessions(SlamSessionState::kClosed));
  EXPECT_EQ(closed, 0);
}

TEST_P(SlamStoreTest, UnreadableTrajectoryRowsAreDataLoss) {
  // Rows damaged beside the store (by hand, by a buggy build): a truncated covariance blob, a
  // missing pose, a 3-D pose without its whole orientation.
  ASSERT_OK(store_->CreateSession(MakeSession("s", "r")));
  ASSERT_OK(store_->WriteCheckpoint("s", Checkpoint("one", 3, 0, 3)));
  const std::string three_bytes = GetParam() == Backend::kSqlite ? "x'010203'" : "'\\x010203'";
  ASSERT_OK(
      database_.Exec("UPDATE slam_trajectory SET covariance = " + three_bytes + " WHERE seq = 1"));
  absl::StatusOr<std::vector<TrajectoryPoseRecord>> loaded = store_->LoadTrajectory("s");
  EXPECT_EQ(CodeOf(loaded), absl::StatusCode::kDataLoss);
  EXPECT_NE(loaded.status().message().find("covariance blob has 3 bytes"), std::string::npos)
      << loaded.status();

  ASSERT_OK(database_.Exec("DELETE FROM slam_trajectory WHERE seq = 1"));
  loaded = store_->LoadTrajectory("s");
  EXPECT_EQ(CodeOf(loaded), absl::StatusCode::kDataLoss);
  EXPECT_NE(loaded.status().message().find("trajectory pose 1 is missing (found seq 2)"),
            std::string::npos)
      << loaded.status();

  ASSERT_OK(database_.Exec("DELETE FROM slam_trajectory WHERE seq = 2"));
  ASSERT_OK(database_.Exec("UPDATE slam_trajectory SET z = 1 WHERE seq = 0"));
  loaded = store_->LoadTrajectory("s");
  EXPECT_EQ(CodeOf(loaded), absl::StatusCode::kDataLoss);
  EXPECT_NE(loaded.status().message().find("has z but not its whole orientation"),
            std::string::npos)
      << loaded.status();
}

TEST_P(SlamStoreTest, RacingCheckpointsOfOneSessionAppendOnce) {
  // Two servers (two stores, each with its own connections) checkpoint one session at the same
  // moment with the same new poses: one appends them; the other, serialised behind it, sees them
  // stored and is refused as a repeat, not with a database error.
  ASSERT_OK(store_->CreateSession(MakeSession("s", "r")));
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<SlamStore> other, OpenSlamStore(database_.db()));
  constexpr int kRounds = 10;
  constexpr int kPoses = 3;
  for (int round = 0; round < kRounds; ++round) {
    const SlamCheckpoint checkpoint = Checkpoint("race", round + 1, round * kPoses, kPoses);
    absl::Status first;
    absl::Status second;
    std::thread racer([&] { second = other->WriteCheckpoint("s", checkpoint); });
    first = store_->WriteCheckpoint("s", checkpoint);
    racer.join();
    EXPECT_NE(first.ok(), second.ok()) << first << " / " << second;
    const absl::Status& refused = first.ok() ? second : first;
    EXPECT_EQ(refused.code(), absl::StatusCode::kInvalidArgument) << refused;
  }
  ASSERT_OK_AND_ASSIGN(auto poses, store_->LoadTrajectory("s"));
  EXPECT_EQ(poses.size(), static_cast<size_t>(kRounds * kPoses));
}

// Leases (issue 19). The expiry tests use a ttl of 0.2 s and wait 0.5 s: behaviour with generous
// margins, not timing measurements.
constexpr double kLongTtl = 30;
constexpr double kShortTtl = 0.2;
void WaitPastShortTtl() { std::this_thread::sleep_for(std::chrono::milliseconds(500)); }

SlamCheckpoint Fenced(SlamCheckpoint checkpoint, const std::string& owner) {
  checkpoint.lease_owner = owner;
  return checkpoint;
}

TEST_P(SlamStoreTest, AnotherOwnerIsRefusedAnUnexpiredLeaseAndTheHolderRenews) {
  ASSERT_OK(store_->CreateSession(MakeSession("s", "r")));
  ASSERT_OK_AND_ASSIGN(SlamSessionRecord fresh, store_->GetSession("s"));
  EXPECT_TRUE(fresh.lease.owner.empty());
  EXPECT_TRUE(fresh.lease.address.empty());
  EXPECT_EQ(fresh.lease.expires_at, 0);

  ASSERT_OK_AND_ASSIGN(SlamLease taken, store_->AcquireLease("s", "A", "a.example:1", kLongTtl));
  EXPECT_EQ(taken.owner, "A");
  EXPECT_EQ(taken.address, "a.example:1");
  EXPECT_GT(taken.expires_at, 0);

  // Get and List show the lease as stored.
  ASSERT_OK_AND_ASSIGN(SlamSessionRecord got, store_->GetSession("s"));
  EXPECT_EQ(got.lease.owner, "A");
  EXPECT_EQ(got.lease.address, "a.example:1");
  EXPECT_EQ(got.lease.expires_at, taken.expires_at);
  ASSERT_OK_AND_ASSIGN(auto listed, store_->ListSessions(""));
  ASSERT_EQ(listed.size(), 1u);
  EXPECT_EQ(listed[0].lease.owner, "A");
  EXPECT_EQ(listed[0].lease.address, "a.example:1");
  EXPECT_EQ(listed[0].lease.expires_at, taken.expires_at);

  // Another owner gets the lease as it stands: A's, unchanged, so it can redirect to A.
  ASSERT_OK_AND_ASSIGN(SlamLease refused, store_->AcquireLease("s", "B", "b.example:2", kLongTtl));
  EXPECT_EQ(refused.owner, "A");
  EXPECT_EQ(refused.address, "a.example:1");
  EXPECT_EQ(refused.expires_at, taken.expires_at);

  // The holder renews: a longer ttl makes the growth certain whatever the clock's resolution.
  ASSERT_OK_AND_ASSIGN(SlamLease renewed,
                       store_->AcquireLease("s", "A", "a.example:1", 2 * kLongTtl));
  EXPECT_EQ(renewed.owner, "A");
  EXPECT_GT(renewed.expires_at, taken.expires_at);
  ASSERT_OK_AND_ASSIGN(got, store_->GetSession("s"));
  EXPECT_EQ(got.lease.expires_at, renewed.expires_at);
}

TEST_P(SlamStoreTest, AnExpiredLeaseIsTakenOver) {
  ASSERT_OK(store_->CreateSession(MakeSession("s", "r")));
  ASSERT_OK_AND_ASSIGN(SlamLease first, store_->AcquireLease("s", "A", "a:1", kShortTtl));
  ASSERT_EQ(first.owner, "A");
  WaitPastShortTtl();
  ASSERT_OK_AND_ASSIGN(SlamLease second, store_->AcquireLease("s", "B", "b:2", kLongTtl));
  EXPECT_EQ(second.owner, "B");
  EXPECT_EQ(second.address, "b:2");
  EXPECT_GT(second.expires_at, first.expires_at);
  // And now A is the one refused.
  ASSERT_OK_AND_ASSIGN(SlamLease refused, store_->AcquireLease("s", "A", "a:1", kLongTtl));
  EXPECT_EQ(refused.owner, "B");
}

TEST_P(SlamStoreTest, ReleaseLetsAnotherOwnerTakeTheSessionAtOnce) {
  ASSERT_OK(store_->CreateSession(MakeSession("s", "r")));
  ASSERT_OK_AND_ASSIGN(SlamLease taken, store_->AcquireLease("s", "A", "a:1", kLongTtl));
  ASSERT_EQ(taken.owner, "A");
  // Releasing a lease one does not hold is a no-op, not an error.
  ASSERT_OK(store_->ReleaseLease("s", "B"));
  ASSERT_OK_AND_ASSIGN(SlamSessionRecord got, store_->GetSession("s"));
  EXPECT_EQ(got.lease.owner, "A");

  ASSERT_OK(store_->ReleaseLease("s", "A"));
  ASSERT_OK_AND_ASSIGN(got, store_->GetSession("s"));
  EXPECT_TRUE(got.lease.owner.empty());
  EXPECT_TRUE(got.lease.address.empty());
  EXPECT_EQ(got.lease.expires_at, 0);
  ASSERT_OK(store_->ReleaseLease("s", "A"));  // again: nothing held, still OK

  ASSERT_OK_AND_ASSIGN(SlamLease next, store_->AcquireLease("s", "B", "b:2", kLongTtl));
  EXPECT_EQ(next.owner, "B");
  EXPECT_EQ(next.address, "b:2");
}

TEST_P(SlamStoreTest, LeaseErrors) {
  ASSERT_OK(store_->CreateSession(MakeSession("s", "r")));
  EXPECT_EQ(CodeOf(store_->AcquireLease("nope", "A", "a:1", kLongTtl)),
            absl::StatusCode::kNotFound);
  EXPECT_EQ(CodeOf(store_->ReleaseLease("nope", "A")), absl::StatusCode::kNotFound);
  EXPECT_EQ(CodeOf(store_->AcquireLease("s", "", "a:1", kLongTtl)),
            absl::StatusCode::kInvalidArgument);
  for (double ttl : {0.0, -1.0, std::numeric_limits<double>::quiet_NaN(),
                     std::numeric_limits<double>::infinity()}) {
    EXPECT_EQ(CodeOf(store_->AcquireLease("s", "A", "a:1", ttl)),
              absl::StatusCode::kInvalidArgument)
        << ttl;
  }
  ASSERT_OK_AND_ASSIGN(SlamSessionRecord untouched, store_->GetSession("s"));
  EXPECT_TRUE(untouched.lease.owner.empty());

  ASSERT_OK(store_->CloseSession("s", Checkpoint("final", 1, 0, 1)));
  absl::StatusOr<SlamLease> closed = store_->AcquireLease("s", "A", "a:1", kLongTtl);
  EXPECT_EQ(CodeOf(closed), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(closed.status().message().find("is closed"), std::string::npos) << closed.status();
}

TEST_P(SlamStoreTest, CheckpointsAreFencedByTheLease) {
  ASSERT_OK(store_->CreateSession(MakeSession("s", "r")));
  ASSERT_OK_AND_ASSIGN(SlamLease taken, store_->AcquireLease("s", "A", "a:1", kShortTtl));
  ASSERT_EQ(taken.owner, "A");
  ASSERT_OK(store_->WriteCheckpoint("s", Fenced(Checkpoint("a one", 2, 0, 2), "A")));
  // Expired but not taken over: A's lease still fences for A.
  WaitPastShortTtl();
  ASSERT_OK(store_->WriteCheckpoint("s", Fenced(Checkpoint("a two", 3, 2, 1), "A")));

  ASSERT_OK_AND_ASSIGN(SlamLease successor,
                       store_->AcquireLease("s", "B", "b.example:2", kLongTtl));
  ASSERT_EQ(successor.owner, "B");
  // A, which lost the lease, writes nothing, and is told who has the session.
  const absl::Status lost =
      store_->WriteCheckpoint("s", Fenced(Checkpoint("a late", 9, 3, 2), "A"));
  EXPECT_EQ(lost.code(), absl::StatusCode::kFailedPrecondition) << lost;
  EXPECT_NE(lost.message().find("held by another server (b.example:2)"), std::string::npos) << lost;
  EXPECT_NE(lost.message().find("lease was lost"), std::string::npos) << lost;
  EXPECT_EQ(CodeOf(store_->CloseSession("s", Fenced(Checkpoint("a final", 9, 3, 0), "A"))),
            absl::StatusCode::kFailedPrecondition);
  ASSERT_OK_AND_ASSIGN(SlamSessionRecord session, store_->GetSession("s"));
  EXPECT_EQ(session.state, SlamSessionState::kOpen);
  EXPECT_EQ(session.checkpoint, "a two");
  EXPECT_EQ(session.scans_processed, 3);
  EXPECT_EQ(session.trajectory_length, 3);
  EXPECT_EQ(session.lease.owner, "B");
  ASSERT_OK_AND_ASSIGN(int64_t stored_poses, database_.CountRows("slam_trajectory"));
  EXPECT_EQ(stored_poses, 3);

  // The holder's fenced checkpoint and an unfenced one are written.
  ASSERT_OK(store_->WriteCheckpoint("s", Fenced(Checkpoint("b one", 4, 3, 1), "B")));
  ASSERT_OK(store_->WriteCheckpoint("s", Checkpoint("unfenced", 5, 4, 1)));
  ASSERT_OK_AND_ASSIGN(session, store_->GetSession("s"));
  EXPECT_EQ(session.checkpoint, "unfenced");
  EXPECT_EQ(session.trajectory_length, 5);

  // Once released, nobody holds the session: a fenced write is refused too.
  ASSERT_OK(store_->ReleaseLease("s", "B"));
  EXPECT_EQ(CodeOf(store_->WriteCheckpoint("s", Fenced(Checkpoint("b late", 6, 5, 1), "B"))),
            absl::StatusCode::kFailedPrecondition);
}

TEST_P(SlamStoreTest, ClosingGivesTheLeaseUp) {
  ASSERT_OK(store_->CreateSession(MakeSession("s", "r")));
  ASSERT_OK_AND_ASSIGN(SlamLease taken, store_->AcquireLease("s", "A", "a:1", kLongTtl));
  ASSERT_EQ(taken.owner, "A");
  ASSERT_OK(store_->CloseSession("s", Fenced(Checkpoint("final", 2, 0, 2), "A")));
  ASSERT_OK_AND_ASSIGN(SlamSessionRecord session, store_->GetSession("s"));
  EXPECT_EQ(session.state, SlamSessionState::kClosed);
  EXPECT_TRUE(session.lease.owner.empty());
  EXPECT_TRUE(session.lease.address.empty());
  EXPECT_EQ(session.lease.expires_at, 0);
  ASSERT_OK_AND_ASSIGN(auto listed, store_->ListSessions(""));
  ASSERT_EQ(listed.size(), 1u);
  EXPECT_TRUE(listed[0].lease.owner.empty());
}

TEST_P(SlamStoreTest, RacingAcquiresGrantTheLeaseOnce) {
  // Two servers (two stores, each with its own connections) ask for one session's lease at the
  // same moment: exactly one gets it, and the other is told who did.
  ASSERT_OK(store_->CreateSession(MakeSession("s", "r")));
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<SlamStore> other, OpenSlamStore(database_.db()));
  constexpr int kRounds = 20;
  for (int round = 0; round < kRounds; ++round) {
    absl::StatusOr<SlamLease> first;
    absl::StatusOr<SlamLease> second;
    std::thread racer([&] { second = other->AcquireLease("s", "B", "b:2", kLongTtl); });
    first = store_->AcquireLease("s", "A", "a:1", kLongTtl);
    racer.join();
    ASSERT_OK(first.status());
    ASSERT_OK(second.status());
    const bool a_won = first->owner == "A";
    const bool b_won = second->owner == "B";
    EXPECT_NE(a_won, b_won) << "round " << round;
    const std::string winner = a_won ? "A" : "B";
    EXPECT_EQ(first->owner, winner) << "round " << round;
    EXPECT_EQ(second->owner, winner) << "round " << round;
    ASSERT_OK(store_->ReleaseLease("s", winner));
  }
}

TEST_P(SlamStoreTest, TheTrajectoryForeignKeyCascades) {
  // Each backend's catalogue: the trajectory's one foreign key is to the session, ON DELETE
  // CASCADE.
  const std::string cascades =
      GetParam() == Backend::kSqlite
          ? "SELECT COUNT(*) FROM pragma_foreign_key_list('slam_trajectory') "
            "WHERE \"table\" = 'slam_session' AND on_delete = 'CASCADE'"
          : "SELECT COUNT(*) FROM pg_constraint WHERE contype = 'f' "
            "AND conrelid = 'slam_trajectory'::regclass "
            "AND confrelid = 'slam_session'::regclass AND confdeltype = 'c'";
  const std::string all_keys =
      GetParam() == Backend::kSqlite
          ? "SELECT COUNT(*) FROM pragma_foreign_key_list('slam_trajectory')"
          : "SELECT COUNT(*) FROM pg_constraint WHERE contype = 'f' "
            "AND conrelid = 'slam_trajectory'::regclass";
  ASSERT_OK_AND_ASSIGN(int64_t keys, database_.QueryInt(all_keys));
  EXPECT_EQ(keys, 1);
  ASSERT_OK_AND_ASSIGN(int64_t cascading, database_.QueryInt(cascades));
  EXPECT_EQ(cascading, 1);
}

TEST_P(SlamStoreTest, SurvivesReopenAndSharesTheDatabaseWithTheCrossingStore) {
  {
    ASSERT_OK_AND_ASSIGN(auto crossings, OpenCrossingStore(database_.db()));
    ASSERT_OK(crossings->CreateDatabase("city", "{}"));
    ASSERT_OK(store_->CreateSession(MakeSession("s", "r")));
    ASSERT_OK(store_->WriteCheckpoint("s", Checkpoint("one", 3, 0, 3)));
  }
  store_.reset();
  ASSERT_OK_AND_ASSIGN(auto store, OpenSlamStore(database_.db()));
  ASSERT_OK_AND_ASSIGN(SlamSessionRecord session, store->GetSession("s"));
  EXPECT_EQ(session.checkpoint, "one");
  EXPECT_EQ(session.scans_processed, 3);
  ASSERT_OK_AND_ASSIGN(auto poses, store->LoadTrajectory("s"));
  EXPECT_EQ(poses.size(), 3u);
  ASSERT_OK_AND_ASSIGN(auto crossings, OpenCrossingStore(database_.db()));
  ASSERT_OK_AND_ASSIGN(auto dbs, crossings->ListDatabases());
  EXPECT_EQ(dbs.size(), 1u);
}

// The journal (issue 21): accepted messages kept until a checkpoint includes them.
std::vector<SlamJournalEntry> Journal(const std::string& id, int64_t first, int count) {
  std::vector<SlamJournalEntry> entries;
  for (int64_t seq = first; seq < first + count; ++seq) {
    entries.push_back({id, seq, std::string("message\0", 8) + std::to_string(seq)});
  }
  return entries;
}

std::vector<int64_t> SeqsOf(const std::vector<SlamJournalEntry>& entries) {
  std::vector<int64_t> seqs;
  for (const SlamJournalEntry& entry : entries) seqs.push_back(entry.seq);
  return seqs;
}

TEST_P(SlamStoreTest, TheJournalKeepsWhatNoCheckpointIncludesAndGoesWithTheSession) {
  ASSERT_OK(store_->CreateSession(MakeSession("s", "r")));
  ASSERT_OK(store_->CreateSession(MakeSession("t", "r")));
  // One batch holds several sessions' messages.
  std::vector<SlamJournalEntry> batch = Journal("s", 1, 4);
  for (const SlamJournalEntry& entry : Journal("t", 1, 2)) batch.push_back(entry);
  ASSERT_OK(store_->AppendJournal(batch, ""));
  ASSERT_OK_AND_ASSIGN(auto journal, store_->LoadJournal("s"));
  EXPECT_EQ(SeqsOf(journal), (std::vector<int64_t>{1, 2, 3, 4}));
  EXPECT_EQ(journal[2].message, std::string("message\0", 8) + "3");  // bytes as given
  EXPECT_EQ(journal[2].session_id, "s");

  // A checkpoint that includes messages 1-3 takes them with it, in its transaction.
  SlamCheckpoint checkpoint = Checkpoint("one", 2, 0, 2);
  checkpoint.journal_through = 3;
  ASSERT_OK(store_->WriteCheckpoint("s", checkpoint));
  ASSERT_OK_AND_ASSIGN(SlamSessionRecord session, store_->GetSession("s"));
  EXPECT_EQ(session.journal_through, 3);
  ASSERT_OK_AND_ASSIGN(journal, store_->LoadJournal("s"));
  EXPECT_EQ(SeqsOf(journal), (std::vector<int64_t>{4}));
  ASSERT_OK_AND_ASSIGN(int64_t rows, database_.CountRows("slam_journal"));
  EXPECT_EQ(rows, 3);  // s: 4; t: 1, 2
  // A checkpoint never goes back in the journal; a seq is stored once.
  checkpoint = Checkpoint("older", 3, 2, 1);
  checkpoint.journal_through = 2;
  EXPECT_EQ(CodeOf(store_->WriteCheckpoint("s", checkpoint)), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf(store_->AppendJournal(Journal("s", 4, 1), "")),
            absl::StatusCode::kAlreadyExists);
  EXPECT_EQ(CodeOf(store_->AppendJournal(Journal("s", 0, 1), "")),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(CodeOf(store_->LoadJournal("nope")), absl::StatusCode::kNotFound);

  // Closing keeps no journal; appending to a closed or unknown session stores nothing and does
  // not fail the batch's other messages.
  SlamCheckpoint final_checkpoint = Checkpoint("final", 3, 2, 1);
  final_checkpoint.journal_through = 3;  // message 4 was never processed: closing drops it too
  ASSERT_OK(store_->CloseSession("s", final_checkpoint));
  std::vector<SlamJournalEntry> late = Journal("s", 5, 1);
  late.push_back({"gone", 1, "x"});
  late.push_back({"t", 3, "y"});
  ASSERT_OK(store_->AppendJournal(late, ""));
  ASSERT_OK_AND_ASSIGN(rows, database_.CountRows("slam_journal"));
  EXPECT_EQ(rows, 3);  // t: 1, 2, 3
  // Deleting a session deletes its journal.
  ASSERT_OK(store_->DeleteSession("t").status());
  ASSERT_OK_AND_ASSIGN(rows, database_.CountRows("slam_journal"));
  EXPECT_EQ(rows, 0);
}

TEST_P(SlamStoreTest, TheJournalIsFencedByTheLease) {
  ASSERT_OK(store_->CreateSession(MakeSession("s", "r")));
  ASSERT_OK_AND_ASSIGN(SlamLease taken, store_->AcquireLease("s", "A", "a:1", kLongTtl));
  ASSERT_EQ(taken.owner, "A");
  ASSERT_OK(store_->AppendJournal(Journal("s", 1, 2), "A"));
  ASSERT_OK(store_->AppendJournal(Journal("s", 3, 1), "B"));  // not B's: skipped
  ASSERT_OK(store_->AppendJournal(Journal("s", 4, 1), ""));   // unfenced
  ASSERT_OK_AND_ASSIGN(auto journal, store_->LoadJournal("s"));
  EXPECT_EQ(SeqsOf(journal), (std::vector<int64_t>{1, 2, 4}));
}

}  // namespace
}  // namespace waymark::storage
