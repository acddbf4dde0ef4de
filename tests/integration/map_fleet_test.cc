// Maps shared by robots (issue 38) on two waymark-server processes sharing one PostgreSQL
// database: a map created on one server is joined by a session created on the other, both see
// the same trajectory list, and a session that moves to the other server (its server stopped) is
// still answered in its map there: the server found its membership in the database.

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>
#include <signal.h>

#include <chrono>
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

TEST(MapFleetTest, ServersOnOneDatabaseShareAMapAndItsMembers) {
  TestDatabase database(Backend::kPostgres);
  WAYMARK_SKIP_WITHOUT(database);
  const std::vector<std::string> flags = {"--slam-workers", "2", "--session-lease-seconds", "2"};
  auto a = ServerProcess::Start(testing::ServerBinary(), database.db(), flags);
  ASSERT_TRUE(a.ok()) << a.status();
  auto b = ServerProcess::Start(testing::ServerBinary(), database.db(), flags);
  ASSERT_TRUE(b.ok()) << b.status();
  auto on_a = FleetMapStub(**a);
  auto on_b = FleetMapStub(**b);

  v1::CreateMapRequest create;
  create.set_name("office");
  v1::Map map;
  ASSERT_TRUE(on_a->CreateMap(FleetMapCtx().get(), create, &map).ok());
  // Both servers keep maps in the one database.
  grpc::Status twice = on_b->CreateMap(FleetMapCtx().get(), create, &map);
  EXPECT_EQ(twice.error_code(), grpc::StatusCode::ALREADY_EXISTS);

  v1::CreateSessionRequest join = TestSessionRequest("r1");
  join.set_map("office");
  v1::Session first, second;
  ASSERT_TRUE(on_b->CreateSession(FleetMapCtx().get(), join, &first).ok());
  join.set_robot_id("r2");
  ASSERT_TRUE(on_a->CreateSession(FleetMapCtx().get(), join, &second).ok());

  v1::GetMapInfoRequest info;
  info.set_name("office");
  v1::Map seen_by_a, seen_by_b;
  ASSERT_TRUE(on_a->GetMapInfo(FleetMapCtx().get(), info, &seen_by_a).ok());
  ASSERT_TRUE(on_b->GetMapInfo(FleetMapCtx().get(), info, &seen_by_b).ok());
  EXPECT_EQ(seen_by_a.SerializeAsString(), seen_by_b.SerializeAsString());
  ASSERT_EQ(seen_by_a.trajectories_size(), 2);
  EXPECT_EQ(seen_by_a.trajectories(0).session_id(), first.session_id());
  EXPECT_TRUE(seen_by_a.trajectories(0).tied_in());
  EXPECT_FALSE(seen_by_a.trajectories(1).tied_in());

  grpc::Status status;
  std::vector<v1::SlamUpdate> answers =
      FleetMapStream(on_b.get(), first.session_id(), 0, 4, &status);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_FALSE(answers.empty());
  for (const v1::SlamUpdate& update : answers) EXPECT_TRUE(update.map_pose().tied_in());

  // B stops cleanly (hands its sessions over at once); A serves the session and, though A
  // loaded its maps before the session joined on B, still answers it in its map.
  on_b.reset();
  ASSERT_EQ((*b)->Stop(SIGTERM), 0);
  answers = FleetMapStream(on_a.get(), first.session_id(), 4, 4, &status);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_FALSE(answers.empty());
  for (const v1::SlamUpdate& update : answers) {
    ASSERT_TRUE(update.has_map_pose());
    EXPECT_EQ(update.map_pose().map(), "office");
    EXPECT_TRUE(update.map_pose().tied_in());
    EXPECT_NEAR(update.map_pose().pose().x(), update.pose().x(), 1e-12);
  }
}

}  // namespace
}  // namespace waymark
