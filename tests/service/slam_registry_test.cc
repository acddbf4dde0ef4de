// SlamRegistry with the real engine and a real SQLite file, no gRPC: admission (time order, beam
// counts, payloads), the bounded queue, one stream per session, checkpoints and resume, isolation
// of concurrent sessions, limits.

#include "server/service/slam/slam_registry.h"

#include <chrono>
#include <cmath>
#include <limits>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "gtest/gtest.h"
#include "storage/slam_store.h"
#include "tests/service/blocking_gate.h"
#include "tests/service/slam_answers.h"
#include "tests/service/slam_test_world.h"
#include "tests/storage/status_testing.h"
#include "tests/storage/temp_dir.h"

namespace waymark::service {
namespace {

using ::waymark::storage::testing::CodeOf;
using ::waymark::storage::testing::TempDir;
using ::waymark::testing::Odom;
using ::waymark::testing::RoomScan;
using ::waymark::testing::TestSessionRequest;

using Gate = BlockingGate;

class SlamRegistryTest : public ::testing::Test {
 protected:
  std::unique_ptr<SlamRegistry> MakeRegistry(SlamRegistryOptions options = {}) {
    if (options.workers == 0) options.workers = 2;
    auto store = storage::OpenSqliteSlamStore(db_path_);
    EXPECT_TRUE(store.ok()) << store.status();
    auto registry = SlamRegistry::Create(std::move(*store), options);
    EXPECT_TRUE(registry.ok()) << registry.status();
    return std::move(*registry);
  }

  // Drives `count` steps of 0.1 m along x (direction +1 or -1), odometry before each scan.
  // Sequences start at `first_seq`; stamps at `t0`.
  static void Drive(SlamRegistry::Stream& stream, int first_step, int count, double direction,
                    uint64_t first_seq = 1) {
    uint64_t seq = first_seq;
    for (int k = first_step; k < first_step + count; ++k) {
      const double x = direction * 0.1 * k;
      const double t = 1.0 + k;
      ASSERT_TRUE(stream.Submit(Odom(seq++, t, x, 0, 0)).ok());
      ASSERT_TRUE(stream.Submit(RoomScan(seq++, t, x, 0, 0)).ok());
    }
  }

  TempDir dir_;
  std::string db_path_ = dir_.File("slam.db");
};

TEST_F(SlamRegistryTest, CreateSessionValidatesAndFillsDefaults) {
  auto registry = MakeRegistry();
  ASSERT_OK_AND_ASSIGN(v1::Session session, registry->CreateSession(TestSessionRequest("r1")));
  EXPECT_EQ(session.session_id().size(), 32u);
  EXPECT_EQ(session.state(), v1::Session::OPEN);
  EXPECT_TRUE(session.resident());
  EXPECT_EQ(session.laser().params().max_range(), 6.0);  // the paper's 6 m, filled in
  EXPECT_TRUE(session.laser().params().has_match_chi2());

  v1::CreateSessionRequest no_robot = TestSessionRequest("");
  EXPECT_EQ(CodeOf(registry->CreateSession(no_robot)), absl::StatusCode::kInvalidArgument);

  v1::CreateSessionRequest bad_range = TestSessionRequest("r1");
  bad_range.mutable_laser()->mutable_params()->set_max_range(-1);
  absl::StatusOr<v1::Session> r = registry->CreateSession(bad_range);
  ASSERT_EQ(CodeOf(r), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(r.status().message().find("laser.params.max_range"), std::string::npos) << r.status();
  EXPECT_NE(r.status().message().find("-1"), std::string::npos) << r.status();

  v1::CreateSessionRequest bad_geometry = TestSessionRequest("r1");
  bad_geometry.mutable_laser()->mutable_laser()->set_beam_count(1);
  r = registry->CreateSession(bad_geometry);
  ASSERT_EQ(CodeOf(r), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(r.status().message().find("beam_count"), std::string::npos) << r.status();

  v1::CreateSessionRequest nan_chi2 = TestSessionRequest("r1");
  nan_chi2.mutable_laser()->mutable_params()->set_match_chi2(std::nan(""));
  EXPECT_EQ(CodeOf(registry->CreateSession(nan_chi2)), absl::StatusCode::kInvalidArgument);
}

TEST_F(SlamRegistryTest, TimeOrderAndBeamCountAreCheckedPerMessage) {
  auto registry = MakeRegistry();
  ASSERT_OK_AND_ASSIGN(v1::Session session, registry->CreateSession(TestSessionRequest("r1")));
  Answers answers;
  ASSERT_OK_AND_ASSIGN(auto stream, registry->OpenStream(session.session_id(), answers.Sink()));

  EXPECT_OK(stream->Submit(Odom(1, 1.0, 0, 0, 0)));
  EXPECT_OK(stream->Submit(RoomScan(2, 1.0, 0, 0, 0)));
  // Duplicate and older stamps, per sensor.
  absl::Status dup_odom = stream->Submit(Odom(3, 1.0, 0, 0, 0));
  EXPECT_EQ(dup_odom.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(dup_odom.message().find("repeats"), std::string::npos) << dup_odom;
  EXPECT_EQ(stream->Submit(Odom(4, 0.5, 0, 0, 0)).code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(stream->Submit(RoomScan(5, 1.0, 0, 0, 0)).code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(stream->Submit(RoomScan(6, 0.9, 0, 0, 0)).code(), absl::StatusCode::kInvalidArgument);
  // A scan stamp may be older than the newest odometry and vice versa: the order is per sensor.
  EXPECT_OK(stream->Submit(Odom(7, 2.0, 0.1, 0, 0)));
  EXPECT_OK(stream->Submit(RoomScan(8, 1.5, 0.05, 0, 0)));
  // Wrong beam count against the session's geometry, and against the scan's own geometry.
  v1::SensorData short_scan = RoomScan(9, 3.0, 0.1, 0, 0);
  short_scan.mutable_scan()->mutable_ranges()->RemoveLast();
  absl::Status beams = stream->Submit(short_scan);
  EXPECT_EQ(beams.code(), absl::StatusCode::kInvalidArgument);
  EXPECT_NE(beams.message().find("180 ranges"), std::string::npos) << beams;
  v1::SensorData own_geometry = RoomScan(10, 3.0, 0.1, 0, 0);
  *own_geometry.mutable_scan()->mutable_geometry() = testing::TestGeometry();
  own_geometry.mutable_scan()->mutable_geometry()->set_beam_count(200);
  EXPECT_EQ(stream->Submit(own_geometry).code(), absl::StatusCode::kInvalidArgument);
  // Oversized, NaN stamp, no payload, another session's id.
  v1::SensorData huge = RoomScan(11, 3.0, 0.1, 0, 0);
  huge.mutable_scan()->mutable_ranges()->Resize(20000, 1.0f);
  EXPECT_EQ(stream->Submit(huge).code(), absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(stream->Submit(RoomScan(12, std::nan(""), 0, 0, 0)).code(),
            absl::StatusCode::kInvalidArgument);
  v1::SensorData empty;
  empty.set_sequence(13);
  EXPECT_EQ(stream->Submit(empty).code(), absl::StatusCode::kInvalidArgument);
  v1::SensorData other = Odom(14, 5.0, 0, 0, 0);
  other.set_session_id("0123456789abcdef0123456789abcdef");
  EXPECT_EQ(stream->Submit(other).code(), absl::StatusCode::kInvalidArgument);
  // NaN, infinite and negative ranges are no-returns, not errors.
  v1::SensorData holes = RoomScan(15, 3.0, 0.1, 0, 0);
  holes.mutable_scan()->set_ranges(0, std::numeric_limits<float>::quiet_NaN());
  holes.mutable_scan()->set_ranges(1, std::numeric_limits<float>::infinity());
  holes.mutable_scan()->set_ranges(2, -1.0f);
  EXPECT_OK(stream->Submit(holes));
  // The scan's own geometry, agreeing with its ranges, is accepted.
  v1::SensorData own_ok = RoomScan(16, 4.0, 0.1, 0, 0);
  *own_ok.mutable_scan()->mutable_geometry() = testing::TestGeometry();
  EXPECT_OK(stream->Submit(own_ok));
  stream->Close();

  const std::vector<v1::SlamUpdate> updates = answers.Get();
  ASSERT_EQ(updates.size(), 4u);
  const uint64_t expected_seq[] = {2, 8, 15, 16};
  for (size_t i = 0; i < updates.size(); ++i) {
    EXPECT_EQ(updates[i].sequence(), expected_seq[i]);
    EXPECT_FALSE(updates[i].has_rejection()) << updates[i].rejection().message();
    EXPECT_EQ(updates[i].scans_processed(), i + 1);
    EXPECT_EQ(updates[i].covariance_size(), 9);
  }
  ASSERT_OK_AND_ASSIGN(v1::Session after, registry->GetSession(session.session_id()));
  EXPECT_EQ(after.scans_processed(), 4u);
  EXPECT_EQ(after.messages_rejected(), 10u);
  EXPECT_EQ(after.messages_dropped(), 0u);
  EXPECT_EQ(after.last_scan_stamp(), 4.0);
}

TEST_F(SlamRegistryTest, AFullQueueRejectsWithResourceExhaustedAndDoesNotGrow) {
  Gate gate;
  SlamRegistryOptions options;
  options.queue_capacity = 3;
  options.workers = 1;
  options.before_process = [&gate](const std::string&) { gate.Enter(); };
  auto registry = MakeRegistry(options);
  ASSERT_OK_AND_ASSIGN(v1::Session session, registry->CreateSession(TestSessionRequest("r1")));
  Answers answers;
  ASSERT_OK_AND_ASSIGN(auto stream, registry->OpenStream(session.session_id(), answers.Sink()));

  ASSERT_OK(stream->Submit(RoomScan(1, 1.0, 0, 0, 0)));
  gate.WaitEntered(1);  // the worker holds scan 1; the queue is empty again
  for (int k = 2; k <= 4; ++k) ASSERT_OK(stream->Submit(RoomScan(k, k, 0, 0, 0)));
  for (int k = 5; k <= 20; ++k) {
    absl::Status full = stream->Submit(RoomScan(k, k, 0, 0, 0));
    ASSERT_EQ(full.code(), absl::StatusCode::kResourceExhausted) << full;
    EXPECT_NE(full.message().find("queue is full"), std::string::npos) << full;
  }
  ASSERT_OK_AND_ASSIGN(v1::Session full, registry->GetSession(session.session_id()));
  EXPECT_EQ(full.queued_messages(), 3u);
  EXPECT_EQ(full.messages_dropped(), 16u);
  EXPECT_EQ(full.messages_rejected(), 16u);
  // A dropped message did not advance the stamp: resending it is accepted once there is room.
  gate.Open();
  stream->Close();
  ASSERT_OK_AND_ASSIGN(auto again, registry->OpenStream(session.session_id(), answers.Sink()));
  ASSERT_OK(again->Submit(RoomScan(5, 5.0, 0, 0, 0)));
  again->Close();
  const std::vector<v1::SlamUpdate> updates = answers.Get();
  ASSERT_EQ(updates.size(), 5u);
  for (size_t i = 0; i < updates.size(); ++i) {
    EXPECT_EQ(updates[i].sequence(), i + 1);  // in order, none lost
    EXPECT_FALSE(updates[i].has_rejection());
  }
}

TEST_F(SlamRegistryTest, OneStreamPerSessionAndClosedSessionsStayReadable) {
  auto registry = MakeRegistry();
  ASSERT_OK_AND_ASSIGN(v1::Session session, registry->CreateSession(TestSessionRequest("r1")));
  const std::string id = session.session_id();
  Answers answers;
  ASSERT_OK_AND_ASSIGN(auto stream, registry->OpenStream(id, answers.Sink()));
  EXPECT_EQ(CodeOf(registry->OpenStream("0123456789abcdef0123456789abcdef", answers.Sink())),
            absl::StatusCode::kNotFound);
  EXPECT_EQ(CodeOf(registry->CloseSession(id)), absl::StatusCode::kFailedPrecondition);

  Drive(*stream, 0, 5, 1.0);
  stream->Close();
  ASSERT_OK_AND_ASSIGN(v1::Session closed, registry->CloseSession(id));
  EXPECT_EQ(closed.state(), v1::Session::CLOSED);
  EXPECT_EQ(closed.scans_processed(), 5u);
  EXPECT_FALSE(closed.resident());
  EXPECT_GT(closed.checkpoint_at_unix(), 0);
  EXPECT_EQ(CodeOf(registry->OpenStream(id, answers.Sink())), absl::StatusCode::kFailedPrecondition);
  EXPECT_EQ(CodeOf(registry->CloseSession(id)), absl::StatusCode::kFailedPrecondition);
  ASSERT_OK_AND_ASSIGN(v1::Trajectory trajectory, registry->GetTrajectory(id));
  EXPECT_EQ(trajectory.poses_size(), 5);
  ASSERT_OK_AND_ASSIGN(v1::SegmentMap map, registry->GetMap(id));
  EXPECT_EQ(map.session_id(), id);
  ASSERT_OK_AND_ASSIGN(v1::ListSessionsResponse list, registry->ListSessions("r1"));
  ASSERT_EQ(list.sessions_size(), 1);
  EXPECT_EQ(list.sessions(0).state(), v1::Session::CLOSED);
  EXPECT_EQ(CodeOf(registry->GetMap("0123456789abcdef0123456789abcdef")),
            absl::StatusCode::kNotFound);
}

// A robot that reconnects while its old stream is still attached (its connection died unnoticed,
// or it cancelled the stream and the server has not seen it yet) gets the session: the old stream
// is cancelled and accepts nothing more, what it had accepted is processed first (the new
// stream's start counts it, the old sink gets its answers), and the old stream's Close does not
// detach the new one. It used to be refused "already has an open stream" (the issue 21 campaign:
// 87 reconnects refused).
TEST_F(SlamRegistryTest, ANewStreamTakesTheSessionOverFromAnAttachedOne) {
  Gate gate;
  SlamRegistryOptions options;
  options.workers = 1;
  options.before_process = [&gate](const std::string&) { gate.Enter(); };
  auto registry = MakeRegistry(options);
  ASSERT_OK_AND_ASSIGN(v1::Session session, registry->CreateSession(TestSessionRequest("r1")));
  const std::string id = session.session_id();
  Answers old_answers, new_answers;
  int cancelled = 0;
  ASSERT_OK_AND_ASSIGN(auto old_stream,
                       registry->OpenStream(id, old_answers.Sink(), [&cancelled] { ++cancelled; }));
  ASSERT_OK(old_stream->Submit(RoomScan(1, 1.0, 0, 0, 0)));
  gate.WaitEntered(1);  // the worker holds scan 1
  ASSERT_OK(old_stream->Submit(RoomScan(2, 2.0, 0, 0, 0)));
  ASSERT_OK(old_stream->Submit(RoomScan(3, 3.0, 0, 0, 0)));

  std::thread opener([&gate] {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    gate.Open();  // whenever it happens, the takeover waits for it (within 10 s)
  });
  absl::StatusOr<std::unique_ptr<SlamRegistry::Stream>> new_stream =
      registry->OpenStream(id, new_answers.Sink());
  opener.join();
  ASSERT_OK(new_stream);
  EXPECT_EQ(cancelled, 1);
  EXPECT_EQ((*new_stream)->start().scans_processed(), 3u);  // all the old stream accepted
  EXPECT_EQ(old_answers.Get().size(), 3u);
  // The old stream's reader may still hand over what it read before the cancel: refused.
  EXPECT_EQ(old_stream->Submit(RoomScan(4, 4.0, 0, 0, 0)).code(), absl::StatusCode::kAborted);
  old_stream->Close();  // returns at once and leaves the new stream attached
  ASSERT_OK((*new_stream)->Submit(RoomScan(4, 4.0, 0, 0, 0)));
  (*new_stream)->Close();
  ASSERT_EQ(new_answers.Get().size(), 1u);
  EXPECT_EQ(new_answers.Get()[0].sequence(), 4u);
  ASSERT_OK_AND_ASSIGN(v1::Session after, registry->GetSession(id));
  EXPECT_EQ(after.scans_processed(), 4u);
}

// A stream that has stopped accepting hands over the same way; the wait for its messages is
// bounded by stream_handover_wait (UNAVAILABLE after it).
TEST_F(SlamRegistryTest, ATakeoverThatWaitsTooLongIsUnavailable) {
  Gate gate;
  SlamRegistryOptions options;
  options.workers = 1;
  options.stream_handover_wait = std::chrono::milliseconds(50);
  options.before_process = [&gate](const std::string&) { gate.Enter(); };
  auto registry = MakeRegistry(options);
  ASSERT_OK_AND_ASSIGN(v1::Session session, registry->CreateSession(TestSessionRequest("r1")));
  const std::string id = session.session_id();
  Answers answers;
  ASSERT_OK_AND_ASSIGN(auto stream, registry->OpenStream(id, answers.Sink()));
  ASSERT_OK(stream->Submit(RoomScan(1, 1.0, 0, 0, 0)));
  gate.WaitEntered(1);
  ASSERT_OK(stream->Submit(RoomScan(2, 2.0, 0, 0, 0)));
  stream->StopAccepting();
  EXPECT_EQ(stream->Submit(RoomScan(3, 3.0, 0, 0, 0)).code(),
            absl::StatusCode::kFailedPrecondition);
  absl::StatusOr<std::unique_ptr<SlamRegistry::Stream>> late =
      registry->OpenStream(id, answers.Sink());
  ASSERT_EQ(CodeOf(late), absl::StatusCode::kUnavailable);
  EXPECT_NE(late.status().message().find("still being processed (1 queued)"), std::string::npos)
      << late.status();
  gate.Open();
  stream->Close();
  ASSERT_OK_AND_ASSIGN(auto next, registry->OpenStream(id, answers.Sink()));
  EXPECT_EQ(next->start().scans_processed(), 2u);
}

TEST_F(SlamRegistryTest, DeleteTakesClosedSessionsAndRefusesOpenOnesWithoutForce) {
  auto registry = MakeRegistry();
  ASSERT_OK_AND_ASSIGN(v1::Session session, registry->CreateSession(TestSessionRequest("r1")));
  const std::string id = session.session_id();
  EXPECT_EQ(CodeOf(registry->DeleteSession("0123456789abcdef0123456789abcdef", false)),
            absl::StatusCode::kNotFound);
  EXPECT_EQ(CodeOf(registry->DeleteSession("", true)), absl::StatusCode::kInvalidArgument);
  Answers answers;
  {
    ASSERT_OK_AND_ASSIGN(auto stream, registry->OpenStream(id, answers.Sink()));
    Drive(*stream, 0, 4, 1.0);
    // Streaming: refused even with force (the stream holds the session).
    absl::StatusOr<v1::DeleteSessionResponse> streaming = registry->DeleteSession(id, true);
    ASSERT_EQ(CodeOf(streaming), absl::StatusCode::kFailedPrecondition);
    EXPECT_NE(streaming.status().message().find("open stream"), std::string::npos)
        << streaming.status();
  }
  absl::StatusOr<v1::DeleteSessionResponse> open = registry->DeleteSession(id, false);
  ASSERT_EQ(CodeOf(open), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(open.status().message().find("is open"), std::string::npos) << open.status();
  EXPECT_NE(open.status().message().find("force"), std::string::npos) << open.status();
  ASSERT_OK(registry->GetSession(id));  // refused means untouched

  ASSERT_OK(registry->CloseSession(id));
  ASSERT_OK_AND_ASSIGN(v1::DeleteSessionResponse deleted, registry->DeleteSession(id, false));
  EXPECT_FALSE(deleted.closed_first());
  EXPECT_EQ(deleted.session().session_id(), id);
  EXPECT_EQ(deleted.session().state(), v1::Session::CLOSED);
  EXPECT_EQ(deleted.session().scans_processed(), 4u);
  EXPECT_EQ(deleted.trajectory_poses(), 4u);
  EXPECT_EQ(CodeOf(registry->GetSession(id)), absl::StatusCode::kNotFound);
  EXPECT_EQ(CodeOf(registry->GetTrajectory(id)), absl::StatusCode::kNotFound);
  EXPECT_EQ(CodeOf(registry->GetMap(id)), absl::StatusCode::kNotFound);
  EXPECT_EQ(CodeOf(registry->DeleteSession(id, true)), absl::StatusCode::kNotFound);
  ASSERT_OK_AND_ASSIGN(v1::ListSessionsResponse list, registry->ListSessions(""));
  EXPECT_EQ(list.sessions_size(), 0);
}

TEST_F(SlamRegistryTest, ForcedDeleteClosesAnOpenSessionFirstInMemoryOrAfterARestart) {
  std::string resident_id, stored_id;
  {
    auto registry = MakeRegistry();
    ASSERT_OK(registry->CreateSession(TestSessionRequest("r1")));  // never touched below
    ASSERT_OK_AND_ASSIGN(v1::Session b, registry->CreateSession(TestSessionRequest("r1")));
    stored_id = b.session_id();
    Answers answers;
    ASSERT_OK_AND_ASSIGN(auto stream, registry->OpenStream(stored_id, answers.Sink()));
    Drive(*stream, 0, 3, 1.0);
    stream->Close();
    ASSERT_OK(registry->Shutdown());  // checkpoints b; both stay open in the store
  }
  auto registry = MakeRegistry();  // a restarted server: nothing resident
  ASSERT_OK_AND_ASSIGN(v1::Session c, registry->CreateSession(TestSessionRequest("r1")));
  resident_id = c.session_id();
  for (const std::string& id : {resident_id, stored_id}) {
    SCOPED_TRACE(id);
    ASSERT_OK_AND_ASSIGN(v1::DeleteSessionResponse deleted, registry->DeleteSession(id, true));
    EXPECT_TRUE(deleted.closed_first());
    EXPECT_EQ(deleted.session().state(), v1::Session::CLOSED);
    EXPECT_EQ(deleted.trajectory_poses(), id == stored_id ? 3u : 0u);
    EXPECT_EQ(CodeOf(registry->GetSession(id)), absl::StatusCode::kNotFound);
  }
  ASSERT_OK_AND_ASSIGN(v1::ListSessionsResponse list, registry->ListSessions(""));
  EXPECT_EQ(list.sessions_size(), 1);  // the untouched one
}

TEST_F(SlamRegistryTest, CheckpointAndResumeAfterARestart) {
  std::string id;
  std::vector<v1::TrajectoryPose> before;
  {
    auto registry = MakeRegistry();
    ASSERT_OK_AND_ASSIGN(v1::Session session, registry->CreateSession(TestSessionRequest("r1")));
    id = session.session_id();
    Answers answers;
    ASSERT_OK_AND_ASSIGN(auto stream, registry->OpenStream(id, answers.Sink()));
    Drive(*stream, 0, 8, 1.0);
    stream->Close();
    ASSERT_OK_AND_ASSIGN(v1::Trajectory trajectory, registry->GetTrajectory(id));
    before.assign(trajectory.poses().begin(), trajectory.poses().end());
    ASSERT_EQ(before.size(), 8u);
    ASSERT_OK(registry->Shutdown());  // what SIGTERM does: checkpoint every resident session
  }
  auto registry = MakeRegistry();
  ASSERT_OK_AND_ASSIGN(v1::Session stored, registry->GetSession(id));
  EXPECT_FALSE(stored.resident());
  EXPECT_EQ(stored.state(), v1::Session::OPEN);
  EXPECT_EQ(stored.scans_processed(), 8u);
  EXPECT_EQ(stored.last_scan_stamp(), 8.0);
  ASSERT_OK_AND_ASSIGN(v1::Trajectory stored_trajectory, registry->GetTrajectory(id));
  ASSERT_EQ(stored_trajectory.poses_size(), 8);
  // The restart changed nothing of it.
  for (size_t i = 0; i < before.size(); ++i) {
    EXPECT_EQ(stored_trajectory.poses(i).stamp(), before[i].stamp());
    EXPECT_EQ(stored_trajectory.poses(i).pose().x(), before[i].pose().x());
    EXPECT_EQ(stored_trajectory.poses(i).pose().y(), before[i].pose().y());
  }

  Answers answers;
  ASSERT_OK_AND_ASSIGN(auto stream, registry->OpenStream(id, answers.Sink()));
  // The restored session still enforces time order.
  EXPECT_EQ(stream->Submit(RoomScan(100, 8.0, 0.7, 0, 0)).code(),
            absl::StatusCode::kInvalidArgument);
  EXPECT_EQ(stream->Submit(Odom(101, 7.5, 0.7, 0, 0)).code(), absl::StatusCode::kInvalidArgument);
  Drive(*stream, 8, 6, 1.0, 200);
  stream->Close();
  const std::vector<v1::SlamUpdate> updates = answers.Get();
  ASSERT_EQ(updates.size(), 6u);
  for (size_t i = 0; i < updates.size(); ++i) EXPECT_EQ(updates[i].scans_processed(), 9 + i);
  // The robot is where it drove (1.3 m along x), within what a 14-scan EKF run should hold.
  EXPECT_NEAR(updates.back().pose().x(), 1.3, 0.25);
  EXPECT_NEAR(updates.back().pose().y(), 0.0, 0.25);

  ASSERT_OK_AND_ASSIGN(v1::Session resumed, registry->GetSession(id));
  EXPECT_TRUE(resumed.resident());
  EXPECT_EQ(resumed.scans_processed(), 14u);
  ASSERT_OK_AND_ASSIGN(v1::Trajectory trajectory, registry->GetTrajectory(id));
  ASSERT_EQ(trajectory.poses_size(), 14);
  // Driving on adds a node after the old scans: those since the last node before the restart
  // take their share of its correction (interpolate_corrections), by millimetres here.
  for (size_t i = 0; i < before.size(); ++i) {
    EXPECT_EQ(trajectory.poses(i).stamp(), before[i].stamp());
    EXPECT_NEAR(trajectory.poses(i).pose().x(), before[i].pose().x(), 0.02);
    EXPECT_NEAR(trajectory.poses(i).pose().y(), before[i].pose().y(), 0.02);
  }
}

TEST_F(SlamRegistryTest, PeriodicCheckpointsEveryNScans) {
  SlamRegistryOptions options;
  options.checkpoint_scans = 4;
  options.checkpoint_seconds = 0;  // count-based only, so the test does not depend on time
  auto registry = MakeRegistry(options);
  ASSERT_OK_AND_ASSIGN(v1::Session session, registry->CreateSession(TestSessionRequest("r1")));
  Answers answers;
  ASSERT_OK_AND_ASSIGN(auto stream, registry->OpenStream(session.session_id(), answers.Sink()));
  Drive(*stream, 0, 9, 1.0);
  stream->Close();
  // Read the file through a second store, as another server process would.
  ASSERT_OK_AND_ASSIGN(auto reader, storage::OpenSqliteSlamStore(db_path_));
  ASSERT_OK_AND_ASSIGN(storage::SlamSessionRecord record, reader->GetSession(session.session_id()));
  EXPECT_EQ(record.scans_processed, 8);  // checkpoints after scans 4 and 8, not yet 9
  EXPECT_EQ(record.trajectory_length, 8);
  EXPECT_FALSE(record.checkpoint.empty());
  ASSERT_OK(registry->CheckpointAll());
  ASSERT_OK_AND_ASSIGN(record, reader->GetSession(session.session_id()));
  EXPECT_EQ(record.scans_processed, 9);
  EXPECT_EQ(record.trajectory_length, 9);
}

TEST_F(SlamRegistryTest, ConcurrentSessionsAreIsolated) {
  auto registry = MakeRegistry();
  constexpr int kSessions = 4;
  std::vector<std::string> ids;
  std::vector<Answers> answers(kSessions);
  for (int s = 0; s < kSessions; ++s) {
    ASSERT_OK_AND_ASSIGN(v1::Session session,
                         registry->CreateSession(TestSessionRequest("robot-" + std::to_string(s))));
    ids.push_back(session.session_id());
  }
  std::vector<std::thread> robots;
  for (int s = 0; s < kSessions; ++s) {
    robots.emplace_back([&, s] {
      auto stream = registry->OpenStream(ids[s], answers[s].Sink());
      ASSERT_TRUE(stream.ok()) << stream.status();
      // Same stamps in every session (order is per session); even robots drive +x, odd -x.
      Drive(**stream, 0, 10, s % 2 == 0 ? 1.0 : -1.0);
      // Session-local order: a duplicate here does not disturb the other sessions.
      EXPECT_EQ((*stream)->Submit(RoomScan(999, 10.0, 0, 0, 0)).code(),
                absl::StatusCode::kInvalidArgument);
      (*stream)->Close();
    });
  }
  for (std::thread& robot : robots) robot.join();
  for (int s = 0; s < kSessions; ++s) {
    const std::vector<v1::SlamUpdate> updates = answers[s].Get();
    ASSERT_EQ(updates.size(), 10u) << "session " << s;
    for (size_t i = 0; i < updates.size(); ++i) {
      EXPECT_EQ(updates[i].sequence(), 2 * i + 2);
      EXPECT_EQ(updates[i].scans_processed(), i + 1);
    }
    EXPECT_NEAR(updates.back().pose().x(), s % 2 == 0 ? 0.9 : -0.9, 0.25) << "session " << s;
    ASSERT_OK_AND_ASSIGN(v1::Session session, registry->GetSession(ids[s]));
    EXPECT_EQ(session.scans_processed(), 10u);
    EXPECT_EQ(session.messages_rejected(), 1u);
  }
}

TEST_F(SlamRegistryTest, MaxSessionsBoundsOpenSessions) {
  SlamRegistryOptions options;
  options.max_sessions = 2;
  auto registry = MakeRegistry(options);
  ASSERT_OK_AND_ASSIGN(v1::Session a, registry->CreateSession(TestSessionRequest("r1")));
  ASSERT_OK(registry->CreateSession(TestSessionRequest("r2")));
  absl::StatusOr<v1::Session> third = registry->CreateSession(TestSessionRequest("r3"));
  ASSERT_EQ(CodeOf(third), absl::StatusCode::kResourceExhausted);
  EXPECT_NE(third.status().message().find("--max-sessions"), std::string::npos);
  ASSERT_OK(registry->CloseSession(a.session_id()));
  EXPECT_OK(registry->CreateSession(TestSessionRequest("r3")));
}

TEST_F(SlamRegistryTest, ShutdownRefusesNewWork) {
  auto registry = MakeRegistry();
  ASSERT_OK_AND_ASSIGN(v1::Session session, registry->CreateSession(TestSessionRequest("r1")));
  Answers answers;
  ASSERT_OK_AND_ASSIGN(auto stream, registry->OpenStream(session.session_id(), answers.Sink()));
  Drive(*stream, 0, 3, 1.0);
  std::thread closer([&] { stream->Close(); });  // the stream handler ends while shutting down
  closer.join();
  ASSERT_OK(registry->Shutdown());
  EXPECT_EQ(answers.Get().size(), 3u);
  EXPECT_EQ(CodeOf(registry->OpenStream(session.session_id(), answers.Sink())),
            absl::StatusCode::kUnavailable);
  EXPECT_EQ(CodeOf(registry->CreateSession(TestSessionRequest("r2"))),
            absl::StatusCode::kUnavailable);
}

}  // namespace
}  // namespace waymark::service
