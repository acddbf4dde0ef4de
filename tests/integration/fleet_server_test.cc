// Several waymark-server processes on one PostgreSQL database (issue 19), end to end over gRPC:
// a view enrolled on one server is recognized on another, a session is served by one server at a
// time (the others name it), and when the server holding a session is killed another takes the
// session over from its last checkpoint once the lease expires.

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "client/lib/channel.h"
#include "client/lib/slam_client.h"
#include "tests/service/slam_test_world.h"
#include "tests/storage/store_backend.h"
#include "tests/support/crossing_test_client.h"
#include "tests/support/server_process.h"
#include "tests/support/synthetic_scene.h"
#include "waymark/v1/slam.grpc.pb.h"

namespace waymark {
namespace {

using storage::testing::Backend;
using storage::testing::TestDatabase;
using testing::Odom;
using testing::RoomScan;
using testing::ServerProcess;
using testing::TestSessionRequest;

constexpr char kLeaseSeconds[] = "2";

std::unique_ptr<grpc::ClientContext> Ctx(int seconds = 60) {
  auto ctx = std::make_unique<grpc::ClientContext>();
  ctx->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(seconds));
  return ctx;
}

struct StreamResult {
  std::optional<v1::StreamStart> start;
  int scans = 0;  // processed-scan answers
  uint64_t last_processed = 0;
  grpc::Status status;
  std::string owner;  // the waymark-session-owner trailer of a redirect
};

// `steps` odometry + scan pairs along x from step `first`, sequences from `seq`.
std::vector<v1::SensorData> Drive(int first, int steps, uint64_t seq) {
  std::vector<v1::SensorData> messages;
  for (int k = first; k < first + steps; ++k) {
    messages.push_back(Odom(seq++, 1.0 + k, 0.1 * k, 0, 0));
    messages.push_back(RoomScan(seq++, 1.0 + k, 0.1 * k, 0, 0));
  }
  return messages;
}

StreamResult RunStream(v1::SlamService::Stub* stub, const std::string& session_id,
                       std::vector<v1::SensorData> messages) {
  StreamResult result;
  auto ctx = Ctx();
  auto stream = stub->StreamSensorData(ctx.get());
  std::thread reader([&] {
    v1::SlamUpdate update;
    while (stream->Read(&update)) {
      if (!result.start.has_value() && update.has_stream_start())
        result.start = update.stream_start();
      if (!update.has_rejection() && update.scans_processed() > 0) {
        ++result.scans;
        result.last_processed = update.scans_processed();
      }
    }
  });
  messages[0].set_session_id(session_id);
  for (const v1::SensorData& message : messages) {
    if (!stream->Write(message)) break;
  }
  stream->WritesDone();
  reader.join();
  result.status = stream->Finish();
  const auto& trailers = ctx->GetServerTrailingMetadata();
  if (auto it = trailers.find("waymark-session-owner"); it != trailers.end()) {
    result.owner = std::string(it->second.data(), it->second.size());
  }
  return result;
}

class FleetServerTest : public ::testing::Test {
 protected:
  FleetServerTest() : database_(Backend::kPostgres) {}

  void SetUp() override {
    WAYMARK_SKIP_WITHOUT(database_);
    a_ = Start();
    b_ = Start();
  }

  void TearDown() override {
    if (HasFailure()) {
      if (a_) std::cerr << "server A log:\n" << a_->Log();
      if (b_) std::cerr << "server B log:\n" << b_->Log();
    }
  }

  std::unique_ptr<ServerProcess> Start() {
    auto server = ServerProcess::Start(
        testing::ServerBinary(), database_.db(),
        {"--slam-workers", "2", "--slam-checkpoint-scans", "3", "--slam-checkpoint-seconds", "0",
         "--session-lease-seconds", kLeaseSeconds});
    EXPECT_TRUE(server.ok()) << server.status();
    return server.ok() ? *std::move(server) : nullptr;
  }

  static std::unique_ptr<v1::SlamService::Stub> Slam(const ServerProcess& server) {
    return v1::SlamService::NewStub(
        grpc::CreateChannel(server.address(), grpc::InsecureChannelCredentials()));
  }

  TestDatabase database_;
  std::unique_ptr<ServerProcess> a_;
  std::unique_ptr<ServerProcess> b_;
};

TEST_F(FleetServerTest, AViewEnrolledOnOneServerIsRecognizedOnTheOther) {
  ASSERT_NE(a_, nullptr);
  ASSERT_NE(b_, nullptr);
  testing::CrossingTestClient on_a(a_->address());
  testing::CrossingTestClient on_b(b_->address());
  v1::CreateDatabaseRequest create;
  create.set_name("campus");
  v1::CrossingDatabase created;
  ASSERT_TRUE(on_a->CreateDatabase(Ctx().get(), create, &created).ok());
  const cv::Mat panorama = testing::MakePanorama(91);
  for (int heading = 0; heading < 360; heading += 90) {
    v1::EnrollViewRequest enroll;
    enroll.set_database("campus");
    enroll.set_crossing("north-gate");
    enroll.set_heading_deg(heading);
    enroll.set_create_crossing(true);
    enroll.mutable_image()->set_data(testing::EncodePng(testing::CropView(panorama, heading)));
    v1::EnrollViewResponse enrolled;
    const grpc::Status status = on_a->EnrollView(Ctx().get(), enroll, &enrolled);
    ASSERT_TRUE(status.ok()) << status.error_message();
  }
  // B follows through LISTEN/NOTIFY; bounded so that a broken sync ends the test.
  v1::RecognizeRequest query;
  query.set_database("campus");
  query.mutable_image()->set_data(testing::EncodePng(testing::CropView(panorama, 10)));
  v1::RecognizeResponse answer;
  for (int i = 0; i < 100; ++i) {
    answer.Clear();
    if (on_b->RecognizeCrossing(Ctx().get(), query, &answer).ok() && answer.recognized()) break;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  EXPECT_TRUE(answer.recognized());
  EXPECT_EQ(answer.crossing(), "north-gate");
}

TEST_F(FleetServerTest, AKilledServersSessionMovesToAnotherWithEverythingItAnswered) {
  ASSERT_NE(a_, nullptr);
  ASSERT_NE(b_, nullptr);
  auto on_a = Slam(*a_);
  auto on_b = Slam(*b_);
  v1::Session session;
  ASSERT_TRUE(on_a->CreateSession(Ctx().get(), TestSessionRequest("robot-1"), &session).ok());
  const std::string id = session.session_id();
  StreamResult first = RunStream(on_a.get(), id, Drive(0, 7, 1));
  ASSERT_TRUE(first.status.ok()) << first.status.error_message();
  ASSERT_EQ(first.scans, 7);

  // While A holds it, B names A: in its list, and when asked to serve it.
  const auto served_by = [&](v1::SlamService::Stub* stub) {
    v1::ListSessionsResponse list;
    EXPECT_TRUE(stub->ListSessions(Ctx().get(), v1::ListSessionsRequest(), &list).ok());
    return list.sessions_size() == 1 ? list.sessions(0).served_by() : std::string("?");
  };
  EXPECT_EQ(served_by(on_b.get()), a_->address());
  StreamResult refused = RunStream(on_b.get(), id, Drive(7, 1, 100));
  EXPECT_EQ(refused.status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_EQ(refused.owner, a_->address()) << refused.status.error_message();
  v1::CloseSessionRequest close;
  close.set_session_id(id);
  v1::Session closed;
  EXPECT_EQ(on_b->CloseSession(Ctx().get(), close, &closed).error_code(),
            grpc::StatusCode::FAILED_PRECONDITION);

  on_a.reset();
  a_->Stop(SIGKILL);  // no shutdown checkpoint, no lease released
  // Once the lease expires B takes the session over, from the checkpoint after scan 6 and A's
  // journal (scan 7); the robot goes on from scan 8. Bounded so that a lease that never expires
  // ends the test.
  StreamResult moved;
  for (int attempt = 0; attempt < 60; ++attempt) {
    moved = RunStream(on_b.get(), id, Drive(7, 3, 200));
    if (moved.status.ok()) break;
    ASSERT_EQ(moved.status.error_code(), grpc::StatusCode::FAILED_PRECONDITION)
        << moved.status.error_message();
    std::this_thread::sleep_for(std::chrono::milliseconds(250));
  }
  ASSERT_TRUE(moved.status.ok()) << moved.status.error_message();
  ASSERT_TRUE(moved.start.has_value());
  EXPECT_TRUE(moved.start->from_checkpoint());
  EXPECT_EQ(moved.start->scans_processed(), 7u);
  EXPECT_EQ(moved.scans, 3);
  EXPECT_EQ(moved.last_processed, 10u);
  v1::GetTrajectoryRequest request;
  request.set_session_id(id);
  v1::Trajectory trajectory;
  ASSERT_TRUE(on_b->GetTrajectory(Ctx().get(), request, &trajectory).ok());
  EXPECT_EQ(trajectory.poses_size(), 10);
  EXPECT_EQ(served_by(on_b.get()), b_->address());
}

TEST_F(FleetServerTest, AServerThatStopsCleanlyHandsItsSessionsOverAtOnce) {
  ASSERT_NE(a_, nullptr);
  ASSERT_NE(b_, nullptr);
  auto on_a = Slam(*a_);
  v1::Session session;
  ASSERT_TRUE(on_a->CreateSession(Ctx().get(), TestSessionRequest("robot-2"), &session).ok());
  StreamResult first = RunStream(on_a.get(), session.session_id(), Drive(0, 4, 1));
  ASSERT_TRUE(first.status.ok()) << first.status.error_message();
  on_a.reset();
  ASSERT_EQ(a_->Stop(SIGTERM), 0);  // saves every session, then releases their leases
  // No waiting for an expiry: the first stream on B is served, with everything A processed.
  StreamResult moved = RunStream(Slam(*b_).get(), session.session_id(), Drive(4, 2, 100));
  ASSERT_TRUE(moved.status.ok()) << moved.status.error_message();
  ASSERT_TRUE(moved.start.has_value());
  EXPECT_EQ(moved.start->scans_processed(), 4u);
  EXPECT_EQ(moved.last_processed, 6u);
}

// What a robot's client does with `--server A,B` (client/lib/fleet_target.h, SlamClient): its
// streams go wherever the fleet channel sends them, follow the server that serves the session
// when another names it, and when that server dies keep trying the fleet until another server
// takes the session over.
TEST_F(FleetServerTest, AFleetClientFollowsItsSessionAndFailsOverWhenItsServerDies) {
  ASSERT_NE(a_, nullptr);
  ASSERT_NE(b_, nullptr);
  v1::Session session;
  ASSERT_TRUE(Slam(*a_)->CreateSession(Ctx().get(), TestSessionRequest("robot-3"), &session).ok());
  const std::string id = session.session_id();  // held by A
  client::SlamClientOptions options;
  options.connect = [](const std::string& address) {
    return std::shared_ptr<grpc::ChannelInterface>(client::MakeChannel(address));
  };
  client::SlamClient fleet(client::MakeChannel(b_->address() + "," + a_->address()), options);

  // Streams until one is served (a refusal teaches the client where the session is); returns
  // the scans the session held when the served stream started, or -1.
  const auto stream_until_served = [&](int first, int steps) -> int {
    for (int attempt = 0; attempt < 80; ++attempt) {
      std::unique_ptr<client::SensorStream> stream = fleet.StreamSensorData(id);
      absl::StatusOr<v1::StreamStart> start = stream->Hello(absl::Seconds(10));
      if (!start.ok()) {
        const absl::Status ended = stream->Finish();
        EXPECT_TRUE(absl::IsFailedPrecondition(ended) || absl::IsUnavailable(ended)) << ended;
        std::this_thread::sleep_for(std::chrono::milliseconds(250));
        continue;
      }
      for (const v1::SensorData& message : Drive(first, steps, 1)) {
        const absl::Status sent = message.has_scan() ? stream->SendScan(message.scan())
                                                     : stream->SendOdometry(message.odometry());
        EXPECT_TRUE(sent.ok()) << sent;
      }
      const absl::Status finished = stream->Finish();
      EXPECT_TRUE(finished.ok()) << finished;
      return static_cast<int>(start->scans_processed());
    }
    return -1;
  };
  EXPECT_EQ(stream_until_served(0, 7), 0);  // served by A, through B's redirect or directly
  a_->Stop(SIGKILL);
  // B serves it once A's lease expires, from the checkpoint after scan 6 and A's journal.
  EXPECT_EQ(stream_until_served(7, 3), 7);
  v1::GetTrajectoryRequest request;
  request.set_session_id(id);
  v1::Trajectory trajectory;
  ASSERT_TRUE(Slam(*b_)->GetTrajectory(Ctx().get(), request, &trajectory).ok());
  EXPECT_EQ(trajectory.poses_size(), 10);
}

// A session created through a fleet client is served by the server that created it, and the
// client opens its streams there at once. Without that, the balancer alternates between A and B
// and one of the streams below would be a refusal naming the creator.
TEST_F(FleetServerTest, AFleetClientStreamsANewSessionToTheServerThatCreatedIt) {
  ASSERT_NE(a_, nullptr);
  ASSERT_NE(b_, nullptr);
  client::SlamClientOptions options;
  options.connect = [](const std::string& address) {
    return std::shared_ptr<grpc::ChannelInterface>(client::MakeChannel(address));
  };
  client::SlamClient fleet(client::MakeChannel(a_->address() + "," + b_->address()), options);
  absl::StatusOr<v1::Session> created = fleet.CreateSession(TestSessionRequest("robot-6"));
  ASSERT_TRUE(created.ok()) << created.status();
  EXPECT_TRUE(created->served_by() == a_->address() || created->served_by() == b_->address())
      << created->served_by();
  for (int i = 0; i < 4; ++i) {
    std::unique_ptr<client::SensorStream> stream = fleet.StreamSensorData(created->session_id());
    absl::StatusOr<v1::StreamStart> start = stream->Hello(absl::Seconds(10));
    ASSERT_TRUE(start.ok()) << "stream " << i << ": " << start.status() << " / "
                            << stream->Finish();
    EXPECT_TRUE(stream->Finish().ok());
  }
}

// Closing a session through a server that does not serve it: the refusal names the server that
// does, and the client closes it there.
TEST_F(FleetServerTest, AClientClosesASessionAtTheServerThatServesIt) {
  ASSERT_NE(a_, nullptr);
  ASSERT_NE(b_, nullptr);
  v1::Session session;
  ASSERT_TRUE(Slam(*a_)->CreateSession(Ctx().get(), TestSessionRequest("robot-4"), &session).ok());
  client::SlamClientOptions options;
  options.connect = [](const std::string& address) {
    return std::shared_ptr<grpc::ChannelInterface>(client::MakeChannel(address));
  };
  client::SlamClient through_b(client::MakeChannel(b_->address()), options);
  absl::StatusOr<v1::Session> closed = through_b.CloseSession(session.session_id());
  ASSERT_TRUE(closed.ok()) << closed.status();
  EXPECT_EQ(closed->state(), v1::Session::CLOSED);
  // Without following, the same call is the refusal naming A.
  client::SlamClient plain(client::MakeChannel(b_->address()));
  v1::Session other;
  ASSERT_TRUE(Slam(*a_)->CreateSession(Ctx().get(), TestSessionRequest("robot-5"), &other).ok());
  absl::StatusOr<v1::Session> refused = plain.CloseSession(other.session_id());
  EXPECT_EQ(refused.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(refused.status().message().find(a_->address()), absl::string_view::npos)
      << refused.status();
}

}  // namespace
}  // namespace waymark
