// Maps shared by robots (issue 38) on two waymark-server processes sharing one PostgreSQL
// database: a map created on one server is joined by a session created on the other, both see
// the same trajectory list, and a session that moves to the other server (its server stopped) is
// still answered in its map there: the server found its membership in the database. One server
// at a time follows a map's robots (the map's lease): when it dies the other takes the map over
// and goes on from the follow it stored.

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "tests/service/slam_test_world.h"
#include "tests/storage/store_backend.h"
#include "tests/support/server_process.h"
#include "waymark/v1/slam.grpc.pb.h"

namespace waymark {
namespace {

using storage::testing::Backend;
using storage::testing::TestDatabase;
using testing::Odom;
using testing::RoomScan;
using testing::ServerProcess;
using testing::TestSessionRequest;

std::unique_ptr<grpc::ClientContext> FleetMapCtx() {
  auto ctx = std::make_unique<grpc::ClientContext>();
  ctx->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
  return ctx;
}

// The answers with a pose to `steps` odometry + scan pairs from step `first`.
std::vector<v1::SlamUpdate> FleetMapStream(v1::SlamService::Stub* stub,
                                           const std::string& session_id, int first, int steps,
                                           grpc::Status* status) {
  std::vector<v1::SensorData> messages;
  uint64_t seq = 1;
  for (int k = first; k < first + steps; ++k) {
    const double x = -1.5 + 0.3 * k;
    messages.push_back(Odom(seq++, 1.0 + k, x, 0, 0));
    messages.push_back(RoomScan(seq++, 1.0 + k, x, 0, 0));
  }
  messages[0].set_session_id(session_id);
  std::vector<v1::SlamUpdate> answers;
  auto ctx = FleetMapCtx();
  auto stream = stub->StreamSensorData(ctx.get());
  std::thread reader([&] {
    v1::SlamUpdate update;
    while (stream->Read(&update)) {
      if (!update.has_rejection() && update.has_pose()) answers.push_back(update);
    }
  });
  for (const v1::SensorData& message : messages) {
    if (!stream->Write(message)) break;
  }
  stream->WritesDone();
  reader.join();
  *status = stream->Finish();
  return answers;
}

std::unique_ptr<v1::SlamService::Stub> FleetMapStub(const ServerProcess& server) {
  return v1::SlamService::NewStub(
      grpc::CreateChannel(server.address(), grpc::InsecureChannelCredentials()));
}

// Two servers on one PostgreSQL database (session leases of 2 s), and the map "office" created
// on the first.
class MapFleetTest : public ::testing::Test {
 protected:
  MapFleetTest() : database_(Backend::kPostgres) {}

  void SetUp() override {
    WAYMARK_SKIP_WITHOUT(database_);
    std::vector<std::string> flags = {"--slam-workers", "2", "--session-lease-seconds", "2"};
    flags.insert(flags.end(), extra_flags_.begin(), extra_flags_.end());
    auto a = ServerProcess::Start(testing::ServerBinary(), database_.db(), flags);
    ASSERT_TRUE(a.ok()) << a.status();
    auto b = ServerProcess::Start(testing::ServerBinary(), database_.db(), flags);
    ASSERT_TRUE(b.ok()) << b.status();
    a_ = *std::move(a);
    b_ = *std::move(b);
    on_a_ = FleetMapStub(*a_);
    on_b_ = FleetMapStub(*b_);
    create_.set_name("office");
    ASSERT_TRUE(on_a_->CreateMap(FleetMapCtx().get(), create_, &created_).ok());
  }

  TestDatabase database_;
  std::vector<std::string> extra_flags_;  // for both servers
  std::unique_ptr<ServerProcess> a_, b_;
  std::unique_ptr<v1::SlamService::Stub> on_a_, on_b_;
  v1::CreateMapRequest create_;
  v1::Map created_;
};

TEST_F(MapFleetTest, ServersOnOneDatabaseShareAMapAndItsMembers) {
  v1::Map map;
  // Both servers keep maps in the one database.
  grpc::Status twice = on_b_->CreateMap(FleetMapCtx().get(), create_, &map);
  EXPECT_EQ(twice.error_code(), grpc::StatusCode::ALREADY_EXISTS);

  v1::CreateSessionRequest join = TestSessionRequest("r1");
  join.set_map("office");
  v1::Session first, second;
  ASSERT_TRUE(on_b_->CreateSession(FleetMapCtx().get(), join, &first).ok());
  join.set_robot_id("r2");
  ASSERT_TRUE(on_a_->CreateSession(FleetMapCtx().get(), join, &second).ok());

  v1::GetMapInfoRequest info;
  info.set_name("office");
  v1::Map seen_by_a, seen_by_b;
  ASSERT_TRUE(on_a_->GetMapInfo(FleetMapCtx().get(), info, &seen_by_a).ok());
  ASSERT_TRUE(on_b_->GetMapInfo(FleetMapCtx().get(), info, &seen_by_b).ok());
  EXPECT_EQ(seen_by_a.SerializeAsString(), seen_by_b.SerializeAsString());
  ASSERT_EQ(seen_by_a.trajectories_size(), 2);
  EXPECT_EQ(seen_by_a.trajectories(0).session_id(), first.session_id());
  EXPECT_TRUE(seen_by_a.trajectories(0).tied_in());
  EXPECT_FALSE(seen_by_a.trajectories(1).tied_in());

  grpc::Status status;
  std::vector<v1::SlamUpdate> answers =
      FleetMapStream(on_b_.get(), first.session_id(), 0, 4, &status);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_FALSE(answers.empty());
  for (const v1::SlamUpdate& update : answers) EXPECT_TRUE(update.map_pose().tied_in());

  // B stops cleanly (hands its sessions over at once); A serves the session and, though A
  // loaded its maps before the session joined on B, still answers it in its map.
  on_b_.reset();
  ASSERT_EQ(b_->Stop(SIGTERM), 0);
  answers = FleetMapStream(on_a_.get(), first.session_id(), 4, 4, &status);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_FALSE(answers.empty());
  for (const v1::SlamUpdate& update : answers) {
    ASSERT_TRUE(update.has_map_pose());
    EXPECT_EQ(update.map_pose().map(), "office");
    EXPECT_TRUE(update.map_pose().tied_in());
    EXPECT_NEAR(update.map_pose().pose().x(), update.pose().x(), 1e-12);
  }
}

// Polls GetMapInfo on `stub` until `done` holds (a bound far above what the servers take, never
// reached when they work: the test waits for what they do, not for a time).
bool WaitForMap(v1::SlamService::Stub* stub, const std::function<bool(const v1::Map&)>& done,
                v1::Map* map) {
  v1::GetMapInfoRequest info;
  info.set_name("office");
  const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(90);
  while (std::chrono::steady_clock::now() < until) {
    if (stub->GetMapInfo(FleetMapCtx().get(), info, map).ok() && done(*map)) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  return false;
}

TEST_F(MapFleetTest, OneServerAtATimeFollowsAMapsRobotsAndTheNextGoesOnFromItsFollow) {
  v1::Map map;
  EXPECT_TRUE(created_.owner().empty());

  // Robot 1 defines the map frame; robot 2 drives the same room, its start given (the test room
  // is square: a search could not tell its corners apart), and is followed.
  v1::CreateSessionRequest join = TestSessionRequest("r1");
  join.set_map("office");
  v1::Session first, second;
  ASSERT_TRUE(on_a_->CreateSession(FleetMapCtx().get(), join, &first).ok());
  grpc::Status status;
  FleetMapStream(on_a_.get(), first.session_id(), 0, 12, &status);
  ASSERT_TRUE(status.ok()) << status.error_message();
  join.set_robot_id("r2");
  join.mutable_initial_map_pose();  // at the map frame's origin, as robot 1 started
  ASSERT_TRUE(on_a_->CreateSession(FleetMapCtx().get(), join, &second).ok());
  FleetMapStream(on_a_.get(), second.session_id(), 0, 8, &status);
  ASSERT_TRUE(status.ok()) << status.error_message();

  // A follows robot 2 (it holds the map's lease) and stores what the follow found.
  const auto samples_of_second = [&](const v1::Map& m) {
    for (const v1::MapTrajectory& t : m.trajectories()) {
      if (t.session_id() == second.session_id()) return t.origin_samples_size();
    }
    return 0;
  };
  ASSERT_TRUE(WaitForMap(
      on_a_.get(), [&](const v1::Map& m) { return m.owner() == a_->address() && samples_of_second(m) >= 2; },
      &map))
      << "A never followed robot 2: owner '" << map.owner() << "'\n" << a_->Log();
  v1::Map seen_by_b;
  // B, which follows nobody, reads the same follow from the database.
  ASSERT_TRUE(WaitForMap(
      on_b_.get(), [&](const v1::Map& m) { return samples_of_second(m) >= 2; }, &seen_by_b))
      << b_->Log();
  EXPECT_EQ(seen_by_b.owner(), a_->address());
  const int followed_on_a = samples_of_second(seen_by_b);

  // A dies without a word. Once its leases expire B serves robot 2, takes the map over and goes
  // on from the stored follow: more samples, the first ones A's.
  on_a_.reset();
  a_->Signal(SIGKILL);
  ASSERT_TRUE(a_->WaitForExit(absl::Seconds(30)).has_value());
  std::this_thread::sleep_for(std::chrono::milliseconds(2500));  // the session lease (2 s)
  FleetMapStream(on_b_.get(), second.session_id(), 8, 8, &status);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_TRUE(WaitForMap(
      on_b_.get(),
      [&](const v1::Map& m) {
        return m.owner() == b_->address() && samples_of_second(m) > followed_on_a;
      },
      &map))
      << "B never took the map over: owner '" << map.owner() << "', " << samples_of_second(map)
      << " samples\n" << b_->Log();
  const v1::MapTrajectory* on_b_second = nullptr;
  for (const v1::MapTrajectory& t : map.trajectories()) {
    if (t.session_id() == second.session_id()) on_b_second = &t;
  }
  ASSERT_NE(on_b_second, nullptr);
  // The follow's counts went on from A's (stored with its samples); in one room, they all held.
  EXPECT_GE(on_b_second->follow().tried(), seen_by_b.trajectories(1).follow().tried());
  EXPECT_GT(seen_by_b.trajectories(1).follow().matched(), 0u);
  EXPECT_EQ(on_b_second->warning(), "");
  for (int i = 0; i < followed_on_a; ++i) {
    EXPECT_EQ(on_b_second->origin_samples(i).scan(),
              seen_by_b.trajectories(1).origin_samples(i).scan());
  }
  // The same room, the same start: every sample says robot 2's frame is the map frame.
  for (const v1::MapOriginSample& sample : on_b_second->origin_samples()) {
    EXPECT_NEAR(sample.origin().x(), 0.0, 0.05);
    EXPECT_NEAR(sample.origin().y(), 0.0, 0.05);
    EXPECT_NEAR(sample.origin().theta(), 0.0, 0.02);
  }
  // Only when asked: the origin at every node of robot 2, from the graph of its nodes and those
  // samples (B serves its session now): at least one per sample, in scan order, every one the
  // map frame.
  EXPECT_EQ(on_b_second->node_origins_size(), 0);
  v1::GetMapInfoRequest with_nodes;
  with_nodes.set_name("office");
  with_nodes.set_node_origins(true);
  v1::Map detailed;
  ASSERT_TRUE(on_b_->GetMapInfo(FleetMapCtx().get(), with_nodes, &detailed).ok());
  const v1::MapTrajectory* nodes_of_second = nullptr;
  for (const v1::MapTrajectory& t : detailed.trajectories()) {
    if (t.session_id() == second.session_id()) nodes_of_second = &t;
  }
  ASSERT_NE(nodes_of_second, nullptr);
  EXPECT_GE(nodes_of_second->node_origins_size(), on_b_second->origin_samples_size());
  for (int i = 0; i < nodes_of_second->node_origins_size(); ++i) {
    const v1::MapOriginSample& origin = nodes_of_second->node_origins(i);
    if (i > 0) EXPECT_GT(origin.scan(), nodes_of_second->node_origins(i - 1).scan());
    EXPECT_TRUE(origin.has_map_pose());
    EXPECT_NEAR(origin.origin().x(), 0.0, 0.05);
    EXPECT_NEAR(origin.origin().y(), 0.0, 0.05);
    EXPECT_NEAR(origin.origin().theta(), 0.0, 0.02);
  }
}

// The servers never checkpoint a session (by time or by scans): what the map's owner knows of
// a robot on the other server comes from the node feed only (trajectory_feed.h).
class MapFleetFeedTest : public MapFleetTest {
 protected:
  MapFleetFeedTest() {
    extra_flags_ = {"--slam-checkpoint-seconds", "0", "--slam-checkpoint-scans", "0"};
  }
};

// A owns the map (it had two robots of it to follow first); robot 2 then joins on B and drives.
// A follows robot 2 from the nodes B publishes as they come: robot 2 has no checkpoint at all
// (with --slam-map-feed-seconds 0 the owner would have no node of it, and no sample).
TEST_F(MapFleetFeedTest, TheOwnerFollowsARobotOnAnotherServerFromItsPublishedNodes) {
  v1::CreateSessionRequest join = TestSessionRequest("r1");
  join.set_map("office");
  v1::Session first, idle, second;
  ASSERT_TRUE(on_a_->CreateSession(FleetMapCtx().get(), join, &first).ok());
  grpc::Status status;
  FleetMapStream(on_a_.get(), first.session_id(), 0, 12, &status);
  ASSERT_TRUE(status.ok()) << status.error_message();
  // A second robot on A, tied in at its creation: A has a map to follow and takes its lease.
  join.set_robot_id("r0");
  join.mutable_initial_map_pose();
  ASSERT_TRUE(on_a_->CreateSession(FleetMapCtx().get(), join, &idle).ok());
  v1::Map map;
  ASSERT_TRUE(WaitForMap(
      on_a_.get(), [&](const v1::Map& m) { return m.owner() == a_->address(); }, &map))
      << "A never took the map: owner '" << map.owner() << "'\n" << a_->Log();

  // Robot 2 on B, the same room and start as robot 1, in two legs. A follows the first leg.
  join.set_robot_id("r2");
  ASSERT_TRUE(on_b_->CreateSession(FleetMapCtx().get(), join, &second).ok());
  FleetMapStream(on_b_.get(), second.session_id(), 0, 8, &status);
  ASSERT_TRUE(status.ok()) << status.error_message();
  const auto second_of = [&](const v1::Map& m) -> const v1::MapTrajectory* {
    for (const v1::MapTrajectory& t : m.trajectories()) {
      if (t.session_id() == second.session_id()) return &t;
    }
    return nullptr;
  };
  const auto followed_past = [&](const v1::Map& m, uint64_t scan) {
    const v1::MapTrajectory* t = second_of(m);
    if (m.owner() != a_->address() || t == nullptr) return false;
    for (const v1::MapOriginSample& sample : t->origin_samples()) {
      if (sample.scan() > scan) return true;
    }
    return false;
  };
  // Asked of A, which holds every sample in memory (it stores them again only once they moved the
  // origin or ten more came).
  ASSERT_TRUE(WaitForMap(on_a_.get(), [&](const v1::Map& m) { return followed_past(m, 1); }, &map))
      << "A never followed robot 2's first leg: owner '" << map.owner() << "'\nA:\n"
      << a_->Log() << "\nB:\n" << b_->Log();
  // The second leg (scans 9-16) reaches A only as B publishes it: robot 2's record, never
  // checkpointed, shows nothing new (with --slam-map-feed-seconds 0, A holds the first leg
  // for good and this waits in vain).
  FleetMapStream(on_b_.get(), second.session_id(), 8, 8, &status);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_TRUE(WaitForMap(on_a_.get(), [&](const v1::Map& m) { return followed_past(m, 8); }, &map))
      << "A never followed robot 2's second leg from B's feed\nA:\n" << a_->Log() << "\nB:\n"
      << b_->Log();
  EXPECT_NE(b_->Log().find("publishing session " + second.session_id()), std::string::npos);
  // Robot 2 was never checkpointed: its record still shows no scan processed.
  v1::ListSessionsRequest list;
  list.set_robot_id("r2");
  v1::ListSessionsResponse listed;
  ASSERT_TRUE(on_a_->ListSessions(FleetMapCtx().get(), list, &listed).ok());
  ASSERT_EQ(listed.sessions_size(), 1);
  EXPECT_EQ(listed.sessions(0).scans_processed(), 0u);
  // The same room, the same start: every sample says robot 2's frame is the map frame.
  for (const v1::MapOriginSample& sample : second_of(map)->origin_samples()) {
    EXPECT_NEAR(sample.origin().x(), 0.0, 0.05);
    EXPECT_NEAR(sample.origin().y(), 0.0, 0.05);
    EXPECT_NEAR(sample.origin().theta(), 0.0, 0.02);
  }
}

}  // namespace
}  // namespace waymark
