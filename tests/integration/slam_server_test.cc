// The real waymark-server binary, SlamService over gRPC on loopback: bad stream inputs answered
// per message while the stream goes on, stream-level errors, eight robots at once, checkpoint and
// resume across a server restart.

#include <signal.h>

#include <cmath>
#include <filesystem>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include "tests/service/slam_test_world.h"
#include "tests/support/raw_stream.h"
#include "tests/support/server_process.h"
#include "waymark/v1/slam.grpc.pb.h"

namespace waymark {
namespace {

using testing::Odom;
using testing::RoomScan;
using testing::ServerProcess;
using testing::TestSessionRequest;

std::unique_ptr<grpc::ClientContext> Ctx(int seconds = 60) {
  auto ctx = std::make_unique<grpc::ClientContext>();
  ctx->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(seconds));
  return ctx;
}

struct StreamResult {
  std::map<uint64_t, v1::SlamUpdate> by_sequence;
  std::vector<v1::SlamUpdate> scans;  // processed-scan answers in arrival order
  int answers = 0;
  std::optional<v1::StreamStart> start;  // from the first answer
  grpc::Status status;
};

// Streams `messages` (the first one gets `session_id`), half-closes, and collects every answer.
StreamResult RunStream(v1::SlamService::Stub* stub, const std::string& session_id,
                       std::vector<v1::SensorData> messages) {
  StreamResult result;
  auto ctx = Ctx();
  auto stream = stub->StreamSensorData(ctx.get());
  std::thread reader([&] {
    v1::SlamUpdate update;
    while (stream->Read(&update)) {
      ++result.answers;
      if (result.answers == 1 && update.has_stream_start()) result.start = update.stream_start();
      result.by_sequence[update.sequence()] = update;
      // A processed scan has scans_processed >= 1; the answer to a hello has none.
      if (!update.has_rejection() && update.scans_processed() > 0) result.scans.push_back(update);
    }
  });
  if (!messages.empty()) messages[0].set_session_id(session_id);
  for (const v1::SensorData& message : messages) {
    if (!stream->Write(message)) break;
  }
  stream->WritesDone();
  reader.join();
  result.status = stream->Finish();
  return result;
}

// `steps` steps of 0.1 m * direction along x from step `first`, odometry then scan, sequences
// from `seq`.
std::vector<v1::SensorData> Drive(int first, int steps, double direction, uint64_t seq = 1) {
  std::vector<v1::SensorData> messages;
  for (int k = first; k < first + steps; ++k) {
    const double x = direction * 0.1 * k;
    messages.push_back(Odom(seq++, 1.0 + k, x, 0, 0));
    messages.push_back(RoomScan(seq++, 1.0 + k, x, 0, 0));
  }
  return messages;
}

class SlamServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::MakeTempDir("waymark-slam-it");
    StartServer();
  }
  void TearDown() override {
    if (HasFailure() && server_) std::cerr << "server log:\n" << server_->Log();
    server_.reset();
    std::filesystem::remove_all(dir_);
  }
  void StartServer(const std::vector<std::string>& args = {"--slam-workers", "2"}) {
    auto server = ServerProcess::Start(testing::ServerBinary(), dir_ + "/waymark.db", args);
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = std::move(*server);
    channel_ = grpc::CreateChannel(server_->address(), grpc::InsecureChannelCredentials());
    stub_ = v1::SlamService::NewStub(channel_);
  }
  // SIGTERM (the server checkpoints every session in memory before it exits), then start again
  // on the same database. The client's channel is dropped first, as a robot's connection would
  // be: gRPC otherwise holds the shutdown a few seconds for the idle connection.
  void Restart() {
    stub_.reset();
    channel_.reset();
    ASSERT_EQ(server_->Stop(SIGTERM), 0);
    StartServer();
  }
  // Streams the first 7 steps into `id` (all answered), SIGKILLs the server (no shutdown
  // checkpoint) and starts it again with `flags`.
  void SevenScansThenKill(const std::string& id, const std::vector<std::string>& flags) {
    StreamResult before = RunStream(stub_.get(), id, Drive(0, 7, 1.0));
    ASSERT_TRUE(before.status.ok()) << before.status.error_message();
    ASSERT_EQ(before.scans.size(), 7u);
    stub_.reset();
    channel_.reset();
    server_->Stop(SIGKILL);
    StartServer(flags);
  }
  std::string CreateSession(const std::string& robot) {
    v1::Session session;
    const grpc::Status status =
        stub_->CreateSession(Ctx().get(), TestSessionRequest(robot), &session);
    EXPECT_TRUE(status.ok()) << status.error_message();
    return session.session_id();
  }

  std::string dir_;
  std::unique_ptr<ServerProcess> server_;
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<v1::SlamService::Stub> stub_;
};

TEST_F(SlamServerTest, BadMessagesAreRejectedAndTheStreamGoesOn) {
  const std::string id = CreateSession("robot-1");
  std::vector<v1::SensorData> m;
  m.push_back(Odom(1, 1.0, 0, 0, 0));
  m.push_back(RoomScan(2, 1.0, 0, 0, 0));
  m.push_back(Odom(3, 1.0, 0, 0, 0));         // duplicate odometry stamp
  m.push_back(RoomScan(4, 0.5, 0, 0, 0));     // out-of-order scan
  m.push_back(RoomScan(5, 1.0, 0, 0, 0));     // duplicate scan stamp
  v1::SensorData short_scan = RoomScan(6, 2.0, 0.1, 0, 0);
  short_scan.mutable_scan()->mutable_ranges()->Resize(100, 1.0f);  // wrong beam count
  m.push_back(short_scan);
  v1::SensorData huge = RoomScan(7, 2.0, 0.1, 0, 0);
  huge.mutable_scan()->mutable_ranges()->Resize(50000, 1.0f);  // oversized scan
  m.push_back(huge);
  v1::SensorData empty;
  empty.set_sequence(8);  // no payload
  m.push_back(empty);
  m.push_back(Odom(9, 2.0, 0.1, 0, 0));
  v1::SensorData holes = RoomScan(10, 2.0, 0.1, 0, 0);  // NaN / inf / negative: no-returns
  for (int i = 0; i < 20; ++i) {
    holes.mutable_scan()->set_ranges(i, std::numeric_limits<float>::quiet_NaN());
  }
  holes.mutable_scan()->set_ranges(30, std::numeric_limits<float>::infinity());
  holes.mutable_scan()->set_ranges(31, -2.0f);
  m.push_back(holes);
  v1::SensorData nan_stamp = Odom(11, std::nan(""), 0, 0, 0);
  m.push_back(nan_stamp);
  m.push_back(Odom(12, 3.0, 0.2, 0, 0));
  m.push_back(RoomScan(13, 3.0, 0.2, 0, 0));  // good messages after all that are answered
  m.push_back(Odom(14, 3.5, 1e300, 1e300, 0));  // finite, but no robot's odometry
  m.push_back(Odom(15, 4.0, 0.3, 0, 0));
  m.push_back(RoomScan(16, 4.0, 0.3, 0, 0));  // answered, and finite

  StreamResult r = RunStream(stub_.get(), id, m);
  ASSERT_TRUE(r.status.ok()) << r.status.error_message();
  const std::map<uint64_t, int> rejected = {{3, 3}, {4, 3}, {5, 3}, {6, 3},
                                            {7, 3}, {8, 3}, {11, 3}, {14, 3}};
  for (const auto& [seq, code] : rejected) {
    ASSERT_EQ(r.by_sequence.count(seq), 1u) << "no answer for " << seq;
    const v1::SlamUpdate& u = r.by_sequence[seq];
    ASSERT_TRUE(u.has_rejection()) << seq;
    EXPECT_EQ(u.rejection().code(), code) << seq << ": " << u.rejection().message();
    EXPECT_FALSE(u.rejection().message().empty());
    EXPECT_FALSE(u.has_pose());
  }
  EXPECT_NE(r.by_sequence[3].rejection().message().find("odometry stamp 1 repeats"),
            std::string::npos)
      << r.by_sequence[3].rejection().message();
  EXPECT_NE(r.by_sequence[6].rejection().message().find("100 ranges"), std::string::npos);
  EXPECT_NE(r.by_sequence[7].rejection().message().find("50000 ranges"), std::string::npos);
  EXPECT_NE(r.by_sequence[14].rejection().message().find("out of range"), std::string::npos)
      << r.by_sequence[14].rejection().message();
  ASSERT_EQ(r.scans.size(), 4u);
  EXPECT_EQ(r.scans[0].sequence(), 2u);
  EXPECT_EQ(r.scans[1].sequence(), 10u);
  EXPECT_EQ(r.scans[2].sequence(), 13u);
  EXPECT_EQ(r.scans[2].scans_processed(), 3u);
  EXPECT_NEAR(r.scans[2].pose().x(), 0.2, 0.1);
  EXPECT_NEAR(r.scans[3].pose().x(), 0.3, 0.1);
  for (double c : r.scans[3].covariance()) EXPECT_TRUE(std::isfinite(c) && std::abs(c) < 1);
  EXPECT_EQ(r.answers, 12);  // odometry is not answered unless rejected

  v1::GetTrajectoryRequest request;
  request.set_session_id(id);
  v1::Trajectory trajectory;
  ASSERT_TRUE(stub_->GetTrajectory(Ctx().get(), request, &trajectory).ok());
  EXPECT_EQ(trajectory.poses_size(), 4);
  for (const auto& pose : trajectory.poses()) {
    EXPECT_TRUE(std::isfinite(pose.pose().x()) && std::isfinite(pose.pose().y()));
  }
  v1::ListSessionsRequest list_request;
  list_request.set_robot_id("robot-1");
  v1::ListSessionsResponse list;
  ASSERT_TRUE(stub_->ListSessions(Ctx().get(), list_request, &list).ok());
  ASSERT_EQ(list.sessions_size(), 1);
  EXPECT_EQ(list.sessions(0).messages_rejected(), 8u);
  EXPECT_EQ(list.sessions(0).scans_processed(), 4u);
}

// Issue 21: a message that does not parse ends the sensor stream with INVALID_ARGUMENT naming
// it; every message before it was processed and answered. It used to end with OK, and the scans
// after it were silently never answered.
TEST_F(SlamServerTest, AnUnparsableMessageEndsTheStreamWithInvalidArgument) {
  const std::string id = CreateSession("robot-1");
  std::vector<v1::SensorData> before = Drive(0, 30, 1.0);  // 60 messages
  before[0].set_session_id(id);
  testing::RawStream stream(channel_, "/waymark.v1.SlamService/StreamSensorData");
  for (const v1::SensorData& m : before) ASSERT_TRUE(stream.Write(m));
  ASSERT_TRUE(stream.WriteBytes(testing::UnparsableMessage()));
  for (const v1::SensorData& m : Drive(30, 30, 1.0, 61)) stream.Write(m);
  std::vector<v1::SlamUpdate> answers;
  const grpc::Status status = stream.Finish(&answers);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
  EXPECT_NE(status.error_message().find("message 61 of the stream"), std::string::npos)
      << status.error_message();
  ASSERT_EQ(answers.size(), 30u);  // every scan before it (odometry is not answered)
  EXPECT_EQ(answers.back().sequence(), 60u);
  v1::ListSessionsRequest list_request;
  list_request.set_robot_id("robot-1");
  v1::ListSessionsResponse list;
  ASSERT_TRUE(stub_->ListSessions(Ctx().get(), list_request, &list).ok());
  ASSERT_EQ(list.sessions_size(), 1);
  EXPECT_EQ(list.sessions(0).scans_processed(), 30u);
}

TEST_F(SlamServerTest, StreamLevelErrorsEndTheStreamWithTheirStatus) {
  // No session_id on the first message.
  std::vector<v1::SensorData> anonymous = {Odom(1, 1.0, 0, 0, 0)};
  {
    auto ctx = Ctx();
    auto stream = stub_->StreamSensorData(ctx.get());
    ASSERT_TRUE(stream->Write(anonymous[0]));
    stream->WritesDone();
    v1::SlamUpdate update;
    while (stream->Read(&update)) {
    }
    const grpc::Status status = stream->Finish();
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
    EXPECT_NE(status.error_message().find("session_id"), std::string::npos);
  }
  // Unknown session.
  StreamResult unknown =
      RunStream(stub_.get(), "0123456789abcdef0123456789abcdef", Drive(0, 1, 1.0));
  EXPECT_EQ(unknown.status.error_code(), grpc::StatusCode::NOT_FOUND);

  // Closing a session with a stream on it is refused.
  const std::string id = CreateSession("robot-1");
  auto ctx = Ctx();
  auto first = stub_->StreamSensorData(ctx.get());
  std::vector<v1::SensorData> hello = Drive(0, 1, 1.0);
  hello[0].set_session_id(id);
  for (const auto& message : hello) ASSERT_TRUE(first->Write(message));
  v1::SlamUpdate answer;
  ASSERT_TRUE(first->Read(&answer));  // the first stream holds the session now
  EXPECT_FALSE(answer.has_rejection());
  v1::CloseSessionRequest close;
  close.set_session_id(id);
  v1::Session closed;
  EXPECT_EQ(stub_->CloseSession(Ctx().get(), close, &closed).error_code(),
            grpc::StatusCode::FAILED_PRECONDITION);
  // A second stream (the robot reconnecting) takes the session over: the first stream's call
  // is cancelled and the second goes on from what the first had sent.
  StreamResult second = RunStream(stub_.get(), id, Drive(1, 1, 1.0));
  EXPECT_TRUE(second.status.ok()) << second.status.error_message();
  ASSERT_TRUE(second.start.has_value());
  EXPECT_EQ(second.start->scans_processed(), 1u);
  EXPECT_EQ(second.scans.size(), 1u);
  EXPECT_FALSE(first->Read(&answer));
  EXPECT_EQ(first->Finish().error_code(), grpc::StatusCode::CANCELLED);

  // A closed session cannot stream.
  ASSERT_TRUE(stub_->CloseSession(Ctx().get(), close, &closed).ok());
  EXPECT_EQ(closed.state(), v1::Session::CLOSED);
  StreamResult after = RunStream(stub_.get(), id, Drive(2, 1, 1.0));
  EXPECT_EQ(after.status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  // Unknown ids for the unary calls.
  v1::GetMapRequest map_request;
  map_request.set_session_id("nope");
  v1::SegmentMap map;
  EXPECT_EQ(stub_->GetMap(Ctx().get(), map_request, &map).error_code(),
            grpc::StatusCode::NOT_FOUND);
  v1::CreateSessionRequest bad = TestSessionRequest("robot-2");
  bad.mutable_laser()->mutable_params()->set_range_sigma(0);
  v1::Session unused;
  const grpc::Status bad_status = stub_->CreateSession(Ctx().get(), bad, &unused);
  EXPECT_EQ(bad_status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(bad_status.error_message().find("laser.params.range_sigma"), std::string::npos);
}

TEST_F(SlamServerTest, EightRobotsStreamAtOnceAndEachGetsItsOwnAnswers) {
  constexpr int kRobots = 8;
  constexpr int kSteps = 12;
  std::vector<std::string> ids;
  for (int r = 0; r < kRobots; ++r) ids.push_back(CreateSession("robot-" + std::to_string(r)));
  std::vector<StreamResult> results(kRobots);
  std::vector<std::thread> robots;
  for (int r = 0; r < kRobots; ++r) {
    robots.emplace_back([&, r] {
      // Even robots drive +x, odd robots -x; all use the same stamps and sequence numbers.
      results[r] = RunStream(stub_.get(), ids[r], Drive(0, kSteps, r % 2 == 0 ? 1.0 : -1.0));
    });
  }
  for (std::thread& robot : robots) robot.join();
  for (int r = 0; r < kRobots; ++r) {
    const StreamResult& result = results[r];
    ASSERT_TRUE(result.status.ok()) << "robot " << r << ": " << result.status.error_message();
    ASSERT_EQ(result.scans.size(), static_cast<size_t>(kSteps)) << "robot " << r;
    for (int k = 0; k < kSteps; ++k) {
      EXPECT_EQ(result.scans[k].sequence(), static_cast<uint64_t>(2 * k + 2));
      EXPECT_EQ(result.scans[k].scans_processed(), static_cast<uint64_t>(k + 1));
    }
    const double expected_x = (r % 2 == 0 ? 1.0 : -1.0) * 0.1 * (kSteps - 1);
    EXPECT_NEAR(result.scans.back().pose().x(), expected_x, 0.25) << "robot " << r;
  }
  v1::ListSessionsResponse list;
  ASSERT_TRUE(stub_->ListSessions(Ctx().get(), v1::ListSessionsRequest(), &list).ok());
  ASSERT_EQ(list.sessions_size(), kRobots);
  for (const v1::Session& session : list.sessions()) {
    EXPECT_EQ(session.scans_processed(), static_cast<uint64_t>(kSteps));
    EXPECT_EQ(session.messages_rejected(), 0u);
    EXPECT_TRUE(session.resident());
  }
}

TEST_F(SlamServerTest, SessionsCheckpointAndResumeAfterAServerRestart) {
  const std::string id = CreateSession("robot-1");
  StreamResult before = RunStream(stub_.get(), id, Drive(0, 6, 1.0));
  ASSERT_TRUE(before.status.ok()) << before.status.error_message();
  ASSERT_EQ(before.scans.size(), 6u);
  v1::GetTrajectoryRequest trajectory_request;
  trajectory_request.set_session_id(id);
  v1::Trajectory old_trajectory;
  ASSERT_TRUE(stub_->GetTrajectory(Ctx().get(), trajectory_request, &old_trajectory).ok());
  ASSERT_EQ(old_trajectory.poses_size(), 6);

  // SIGTERM: the server checkpoints the session before it exits.
  Restart();

  v1::ListSessionsResponse list;
  ASSERT_TRUE(stub_->ListSessions(Ctx().get(), v1::ListSessionsRequest(), &list).ok());
  ASSERT_EQ(list.sessions_size(), 1);
  EXPECT_EQ(list.sessions(0).session_id(), id);
  EXPECT_EQ(list.sessions(0).state(), v1::Session::OPEN);
  EXPECT_FALSE(list.sessions(0).resident());
  EXPECT_EQ(list.sessions(0).scans_processed(), 6u);
  EXPECT_GT(list.sessions(0).checkpoint_at_unix(), 0);
  v1::Trajectory stored;
  ASSERT_TRUE(stub_->GetTrajectory(Ctx().get(), trajectory_request, &stored).ok());
  ASSERT_EQ(stored.poses_size(), 6);
  // The restart changed nothing of it.
  for (int i = 0; i < old_trajectory.poses_size(); ++i) {
    EXPECT_EQ(stored.poses(i).stamp(), old_trajectory.poses(i).stamp());
    EXPECT_EQ(stored.poses(i).pose().x(), old_trajectory.poses(i).pose().x());
    EXPECT_EQ(stored.poses(i).pose().y(), old_trajectory.poses(i).pose().y());
  }

  // Resume: open the stream on the old id and go on where the robot left off.
  std::vector<v1::SensorData> more = Drive(6, 4, 1.0, 100);
  more.insert(more.begin(), RoomScan(99, 6.0, 0.5, 0, 0));  // already processed before: refused
  StreamResult after = RunStream(stub_.get(), id, more);
  ASSERT_TRUE(after.status.ok()) << after.status.error_message();
  ASSERT_TRUE(after.by_sequence[99].has_rejection());
  EXPECT_EQ(after.by_sequence[99].rejection().code(), 3);
  ASSERT_EQ(after.scans.size(), 4u);
  for (size_t i = 0; i < after.scans.size(); ++i) {
    EXPECT_EQ(after.scans[i].scans_processed(), 7 + i);
  }
  EXPECT_NEAR(after.scans.back().pose().x(), 0.9, 0.25);

  v1::Trajectory trajectory;
  ASSERT_TRUE(stub_->GetTrajectory(Ctx().get(), trajectory_request, &trajectory).ok());
  ASSERT_EQ(trajectory.poses_size(), 10);
  // Driving on adds a node after the old scans: those since the last node before the restart
  // take their share of its correction (interpolate_corrections), by millimetres here.
  for (int i = 0; i < old_trajectory.poses_size(); ++i) {
    EXPECT_EQ(trajectory.poses(i).stamp(), old_trajectory.poses(i).stamp());
    EXPECT_NEAR(trajectory.poses(i).pose().x(), old_trajectory.poses(i).pose().x(), 0.02);
    EXPECT_EQ(trajectory.poses(i).covariance_size(), 9);
  }

  v1::CloseSessionRequest close;
  close.set_session_id(id);
  v1::Session closed;
  ASSERT_TRUE(stub_->CloseSession(Ctx().get(), close, &closed).ok());
  EXPECT_EQ(closed.scans_processed(), 10u);
  // Closed survives a restart too, and stays readable.
  Restart();
  v1::GetMapRequest map_request;
  map_request.set_session_id(id);
  v1::SegmentMap map;
  ASSERT_TRUE(stub_->GetMap(Ctx().get(), map_request, &map).ok());
  EXPECT_EQ(map.session_id(), id);
  ASSERT_TRUE(stub_->GetTrajectory(Ctx().get(), trajectory_request, &trajectory).ok());
  EXPECT_EQ(trajectory.poses_size(), 10);
  StreamResult refused = RunStream(stub_.get(), id, Drive(10, 1, 1.0));
  EXPECT_EQ(refused.status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
}

// Issue 21: every message the server answered is in its journal, so a session resumed after a
// SIGKILL holds all of them, and goes on exactly as a session that was never interrupted.
TEST_F(SlamServerTest, AfterACrashTheSessionHasEveryAnsweredScanAndEqualsAnUninterruptedOne) {
  // Count-based checkpoints only (after scans 3 and 6), so what the journal must add is known.
  const std::vector<std::string> flags = {"--slam-workers", "2", "--slam-checkpoint-scans", "3",
                                          "--slam-checkpoint-seconds", "0"};
  server_.reset();
  StartServer(flags);
  const std::string uninterrupted = CreateSession("robot-1");
  ASSERT_TRUE(RunStream(stub_.get(), uninterrupted, Drive(0, 10, 1.0)).status.ok());
  const std::string id = CreateSession("robot-2");
  ASSERT_NO_FATAL_FAILURE(SevenScansThenKill(id, flags));

  // The 7th scan was answered after the last checkpoint (6): the journal has it.
  StreamResult after = RunStream(stub_.get(), id, Drive(7, 3, 1.0, 100));
  ASSERT_TRUE(after.status.ok()) << after.status.error_message();
  ASSERT_TRUE(after.start.has_value());
  EXPECT_TRUE(after.start->from_checkpoint());
  EXPECT_EQ(after.start->scans_processed(), 7u);
  EXPECT_EQ(after.start->last_scan_stamp(), 7.0);
  ASSERT_EQ(after.scans.size(), 3u);
  EXPECT_EQ(after.scans.back().scans_processed(), 10u);
  for (size_t i = 0; i < after.scans.size(); ++i) EXPECT_FALSE(after.scans[i].has_rejection());

  v1::GetTrajectoryRequest request;
  request.set_session_id(id);
  v1::Trajectory resumed;
  ASSERT_TRUE(stub_->GetTrajectory(Ctx().get(), request, &resumed).ok());
  request.set_session_id(uninterrupted);
  v1::Trajectory reference;
  ASSERT_TRUE(stub_->GetTrajectory(Ctx().get(), request, &reference).ok());
  ASSERT_EQ(resumed.poses_size(), 10);
  ASSERT_EQ(reference.poses_size(), 10);
  for (int i = 0; i < 10; ++i) {
    EXPECT_EQ(resumed.poses(i).stamp(), reference.poses(i).stamp()) << "pose " << i;
    EXPECT_EQ(resumed.poses(i).pose().x(), reference.poses(i).pose().x()) << "pose " << i;
    EXPECT_EQ(resumed.poses(i).pose().y(), reference.poses(i).pose().y()) << "pose " << i;
    EXPECT_EQ(resumed.poses(i).pose().theta(), reference.poses(i).pose().theta()) << "pose " << i;
  }
}

// Without the journal (--slam-journal=false) a crash goes back to the last checkpoint; the
// stream's first answer says where, so the robot can resend what was lost.
TEST_F(SlamServerTest, WithoutTheJournalACrashGoesBackToTheLastPeriodicCheckpoint) {
  server_.reset();
  const std::vector<std::string> flags = {"--slam-workers", "2", "--slam-checkpoint-scans", "3",
                                          "--slam-checkpoint-seconds", "0", "--slam-journal",
                                          "false"};
  StartServer(flags);
  const std::string id = CreateSession("robot-1");
  ASSERT_NO_FATAL_FAILURE(SevenScansThenKill(id, flags));

  v1::ListSessionsResponse list;
  ASSERT_TRUE(stub_->ListSessions(Ctx().get(), v1::ListSessionsRequest(), &list).ok());
  ASSERT_EQ(list.sessions_size(), 1);
  EXPECT_EQ(list.sessions(0).scans_processed(), 6u);  // checkpoints after scans 3 and 6
  EXPECT_EQ(list.sessions(0).last_scan_stamp(), 6.0);
  // The robot resends from the first scan the server does not have (stamp 7) and goes on.
  StreamResult after = RunStream(stub_.get(), id, Drive(6, 3, 1.0, 100));
  ASSERT_TRUE(after.status.ok()) << after.status.error_message();
  ASSERT_TRUE(after.start.has_value());
  EXPECT_TRUE(after.start->from_checkpoint());
  EXPECT_EQ(after.start->scans_processed(), 6u);
  EXPECT_EQ(after.start->last_scan_stamp(), 6.0);
  EXPECT_GT(after.start->checkpoint_at_unix(), 0);
  ASSERT_EQ(after.scans.size(), 3u);
  EXPECT_EQ(after.scans.back().scans_processed(), 9u);
  v1::GetTrajectoryRequest request;
  request.set_session_id(id);
  v1::Trajectory trajectory;
  ASSERT_TRUE(stub_->GetTrajectory(Ctx().get(), request, &trajectory).ok());
  EXPECT_EQ(trajectory.poses_size(), 9);
}

TEST_F(SlamServerTest, DeleteSessionRefusesOpenSessionsUnlessForcedAndForgetsTheDeleted) {
  const std::string open_id = CreateSession("robot-1");
  const std::string closed_id = CreateSession("robot-1");
  ASSERT_TRUE(RunStream(stub_.get(), closed_id, Drive(0, 3, 1.0)).status.ok());
  v1::CloseSessionRequest close;
  close.set_session_id(closed_id);
  v1::Session closed;
  ASSERT_TRUE(stub_->CloseSession(Ctx().get(), close, &closed).ok());

  v1::DeleteSessionRequest request;
  v1::DeleteSessionResponse response;
  request.set_session_id("0123456789abcdef0123456789abcdef");
  EXPECT_EQ(stub_->DeleteSession(Ctx().get(), request, &response).error_code(),
            grpc::StatusCode::NOT_FOUND);
  request.set_session_id(open_id);
  const grpc::Status refused = stub_->DeleteSession(Ctx().get(), request, &response);
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_NE(refused.error_message().find("force"), std::string::npos) << refused.error_message();

  request.set_session_id(closed_id);
  ASSERT_TRUE(stub_->DeleteSession(Ctx().get(), request, &response).ok());
  EXPECT_EQ(response.session().session_id(), closed_id);
  EXPECT_EQ(response.session().scans_processed(), 3u);
  EXPECT_EQ(response.trajectory_poses(), 3u);
  EXPECT_FALSE(response.closed_first());

  request.set_session_id(open_id);
  request.set_force(true);
  ASSERT_TRUE(stub_->DeleteSession(Ctx().get(), request, &response).ok());
  EXPECT_TRUE(response.closed_first());

  // Both are gone, from the list and from every call, also after a restart.
  Restart();
  v1::ListSessionsResponse list;
  ASSERT_TRUE(stub_->ListSessions(Ctx().get(), v1::ListSessionsRequest(), &list).ok());
  EXPECT_EQ(list.sessions_size(), 0);
  v1::GetTrajectoryRequest trajectory_request;
  trajectory_request.set_session_id(closed_id);
  v1::Trajectory trajectory;
  EXPECT_EQ(stub_->GetTrajectory(Ctx().get(), trajectory_request, &trajectory).error_code(),
            grpc::StatusCode::NOT_FOUND);
  EXPECT_EQ(RunStream(stub_.get(), open_id, Drive(0, 1, 1.0)).status.error_code(),
            grpc::StatusCode::NOT_FOUND);
}

// Issue 15: what a session held when a stream attached is in the stream's first answer, and a
// hello (a first message with only the session id) gets it at once.
TEST_F(SlamServerTest, AHelloIsAnsweredWithWhatTheSessionHolds) {
  const std::string id = CreateSession("robot-1");
  StreamResult fresh = RunStream(stub_.get(), id, Drive(0, 3, 1.0));
  ASSERT_TRUE(fresh.status.ok()) << fresh.status.error_message();
  ASSERT_TRUE(fresh.start.has_value());
  EXPECT_FALSE(fresh.start->from_checkpoint());
  EXPECT_EQ(fresh.start->scans_processed(), 0u);

  v1::SensorData hello;
  hello.set_sequence(7);
  StreamResult again = RunStream(stub_.get(), id, {hello});
  ASSERT_TRUE(again.status.ok()) << again.status.error_message();
  ASSERT_EQ(again.answers, 1);
  EXPECT_EQ(again.by_sequence[7].stream_start().scans_processed(), 3u);
  EXPECT_EQ(again.by_sequence[7].stream_start().last_scan_stamp(), 3.0);
  EXPECT_FALSE(again.by_sequence[7].stream_start().from_checkpoint());  // still in memory
  EXPECT_TRUE(again.scans.empty());
}

// Issue 15: a server whose stderr went into a `tee` that was closed died of SIGPIPE at its next
// log line, before its shutdown checkpoint.
TEST_F(SlamServerTest, AServerWhoseStderrReaderIsGoneStillSavesItsSessionsOnSigterm) {
  server_.reset();
  // Checkpoints only at shutdown, so the session's progress is saved by the SIGTERM or not at all.
  auto server = ServerProcess::Start(
      testing::ServerBinary(), dir_ + "/waymark.db",
      {"--slam-workers", "2", "--slam-checkpoint-seconds", "0", "--slam-checkpoint-scans", "0"},
      "127.0.0.1:0", ServerProcess::Stderr::kClosedPipe);
  ASSERT_TRUE(server.ok()) << server.status();  // killed by its first log line before the fix
  server_ = std::move(*server);
  channel_ = grpc::CreateChannel(server_->address(), grpc::InsecureChannelCredentials());
  stub_ = v1::SlamService::NewStub(channel_);
  const std::string id = CreateSession("robot-1");
  StreamResult before = RunStream(stub_.get(), id, Drive(0, 5, 1.0));
  ASSERT_TRUE(before.status.ok()) << before.status.error_message();
  ASSERT_EQ(before.scans.size(), 5u);
  stub_.reset();
  channel_.reset();
  EXPECT_EQ(server_->Stop(SIGTERM), 0);

  StartServer();
  v1::ListSessionsResponse list;
  ASSERT_TRUE(stub_->ListSessions(Ctx().get(), v1::ListSessionsRequest(), &list).ok());
  ASSERT_EQ(list.sessions_size(), 1);
  EXPECT_EQ(list.sessions(0).scans_processed(), 5u);
  EXPECT_GT(list.sessions(0).checkpoint_at_unix(), 0);
}

// Issue 15: on SIGTERM with a robot streaming, the server waited its whole grace for the stream.
// It now saves the session, ends the stream with UNAVAILABLE "server shutting down" and exits.
TEST_F(SlamServerTest, ShutdownEndsOpenStreamsOnceTheirSessionsAreSavedAndExits) {
  server_.reset();
  // A grace far longer than the test's wait: if the server exits within the wait, it did not
  // wait for the stream to end on its own.
  StartServer({"--slam-workers", "2", "--shutdown-grace", "600", "--slam-checkpoint-seconds", "0",
               "--slam-checkpoint-scans", "0"});
  const std::string id = CreateSession("robot-1");
  // Far beyond what the shutdown takes, far below the grace: a server that waits for the grace
  // fails the test here rather than hanging it.
  auto ctx = Ctx(120);
  auto stream = stub_->StreamSensorData(ctx.get());
  std::vector<v1::SensorData> messages = Drive(0, 5, 1.0);
  messages[0].set_session_id(id);
  for (const v1::SensorData& message : messages) ASSERT_TRUE(stream->Write(message));
  for (int answered = 0; answered < 5; ++answered) {
    v1::SlamUpdate update;
    ASSERT_TRUE(stream->Read(&update)) << "answer " << answered;
    ASSERT_FALSE(update.has_rejection()) << update.rejection().message();
  }

  server_->Signal(SIGTERM);  // the stream is open: the robot has not half-closed
  v1::SlamUpdate update;
  while (stream->Read(&update)) {
  }
  const grpc::Status status = stream->Finish();
  // UNAVAILABLE either way, which a robot answers by reconnecting: the server's "server shutting
  // down" status, or, when the process exits before the transport flushed that status (seen on a
  // loaded machine), the closed connection.
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAVAILABLE) << status.error_message();
  EXPECT_TRUE(status.error_message().find("server shutting down") != std::string::npos ||
              status.error_message().find("Socket closed") != std::string::npos)
      << status.error_message();
  stream.reset();
  stub_.reset();
  channel_.reset();
  const std::optional<int> exit_code = server_->WaitForExit(absl::Seconds(120));
  ASSERT_TRUE(exit_code.has_value()) << "still running 120 s after SIGTERM (grace 600 s)\n"
                                     << server_->Log();
  EXPECT_EQ(*exit_code, 0);

  StartServer();
  v1::ListSessionsResponse list;
  ASSERT_TRUE(stub_->ListSessions(Ctx().get(), v1::ListSessionsRequest(), &list).ok());
  ASSERT_EQ(list.sessions_size(), 1);
  EXPECT_EQ(list.sessions(0).scans_processed(), 5u);
  EXPECT_GT(list.sessions(0).checkpoint_at_unix(), 0);
}

}  // namespace
}  // namespace waymark
