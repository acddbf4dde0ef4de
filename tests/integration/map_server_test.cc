// Maps shared by robots (issue 38) against the real waymark-server binary: CreateMap, ListMaps,
// GetMapInfo, DeleteMap and GetMapOccupancyGrid with their errors; laser sessions joining a map at
// creation (the first defines the map frame and is tied in, the next is not yet in the map) and
// their answers' map_pose; a map in use refused for deletion without force; a deleted session
// leaving its map; a map and its trajectories surviving a server restart; and the `waymark map`
// and `waymark slam replay --map --scans` command lines.

#include <signal.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include "storage/map_store.h"
#include "tests/client/carmen_test_log.h"
#include "tests/client/test_util.h"
#include "tests/service/slam_test_world.h"
#include "tests/support/server_process.h"
#include "waymark/v1/slam.grpc.pb.h"

namespace waymark {
namespace {

using testing::Odom;
using testing::RoomScan;
using testing::ServerProcess;
using testing::TestSessionRequest;

std::unique_ptr<grpc::ClientContext> MapCtx() {
  auto ctx = std::make_unique<grpc::ClientContext>();
  ctx->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
  return ctx;
}

// `steps` steps of 0.3 m along x from step `first`, odometry then scan.
std::vector<v1::SensorData> MapDrive(int first, int steps) {
  std::vector<v1::SensorData> messages;
  uint64_t seq = 1;
  for (int k = first; k < first + steps; ++k) {
    const double x = -1.5 + 0.3 * k;
    messages.push_back(Odom(seq++, 1.0 + k, x, 0, 0));
    messages.push_back(RoomScan(seq++, 1.0 + k, x, 0, 0));
  }
  return messages;
}

// Streams `messages` into the session and returns the answers to processed scans with a pose.
std::vector<v1::SlamUpdate> StreamInto(v1::SlamService::Stub* stub, const std::string& session_id,
                                       std::vector<v1::SensorData> messages, grpc::Status* status) {
  std::vector<v1::SlamUpdate> answers;
  auto ctx = MapCtx();
  auto stream = stub->StreamSensorData(ctx.get());
  std::thread reader([&] {
    v1::SlamUpdate update;
    while (stream->Read(&update)) {
      if (!update.has_rejection() && update.has_pose()) answers.push_back(update);
    }
  });
  messages[0].set_session_id(session_id);
  for (const v1::SensorData& message : messages) {
    if (!stream->Write(message)) break;
  }
  stream->WritesDone();
  reader.join();
  *status = stream->Finish();
  return answers;
}

class MapServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::MakeTempDir("waymark-map-it");
    StartServer();
  }
  void TearDown() override {
    if (HasFailure() && server_) std::cerr << "server log:\n" << server_->Log();
    server_.reset();
    std::filesystem::remove_all(dir_);
  }
  void StartServer() {
    // The search that ties robots in from their scans is off: these tests check what a map
    // holds and answers, and a robot tied in while a test reads "not yet in the map" would make
    // them race. The tie itself: map_tie_test.cc.
    auto server = ServerProcess::Start(testing::ServerBinary(), dir_ + "/waymark.db",
                                       {"--slam-workers", "2", "--slam-map-tie", "false"});
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = std::move(*server);
    channel_ = grpc::CreateChannel(server_->address(), grpc::InsecureChannelCredentials());
    stub_ = v1::SlamService::NewStub(channel_);
  }
  void Restart() {
    stub_.reset();
    channel_.reset();
    ASSERT_EQ(server_->Stop(SIGTERM), 0);
    StartServer();
  }

  grpc::Status CreateMap(const std::string& name, v1::Map* map = nullptr) {
    v1::CreateMapRequest request;
    request.set_name(name);
    v1::Map ignored;
    return stub_->CreateMap(MapCtx().get(), request, map != nullptr ? map : &ignored);
  }
  grpc::Status GetMapInfo(const std::string& name, v1::Map* map) {
    v1::GetMapInfoRequest request;
    request.set_name(name);
    return stub_->GetMapInfo(MapCtx().get(), request, map);
  }
  grpc::Status DeleteMap(const std::string& name, bool force, v1::DeleteMapResponse* response) {
    v1::DeleteMapRequest request;
    request.set_name(name);
    request.set_force(force);
    return stub_->DeleteMap(MapCtx().get(), request, response);
  }
  grpc::Status MapSegments(const std::string& name, v1::MapSegmentMap* segments) {
    v1::GetMapSegmentsRequest request;
    request.set_name(name);
    return stub_->GetMapSegments(MapCtx().get(), request, segments);
  }
  int SessionSegments(const std::string& session_id) {
    v1::GetMapRequest request;
    request.set_session_id(session_id);
    v1::SegmentMap map;
    EXPECT_TRUE(stub_->GetMap(MapCtx().get(), request, &map).ok());
    return map.segments_size();
  }
  grpc::Status MapGrid(const std::string& name, v1::MapOccupancyGrid* grid) {
    v1::GetMapOccupancyGridRequest request;
    request.set_name(name);
    return stub_->GetMapOccupancyGrid(MapCtx().get(), request, grid);
  }
  // A session of `robot` joining `map`: its status, and the session in *session.
  grpc::Status Join(const std::string& robot, const std::string& map, v1::Session* session) {
    v1::CreateSessionRequest request = TestSessionRequest(robot);
    request.set_map(map);
    return stub_->CreateSession(MapCtx().get(), request, session);
  }
  int SessionCount() {
    v1::ListSessionsResponse listed;
    EXPECT_TRUE(stub_->ListSessions(MapCtx().get(), {}, &listed).ok());
    return listed.sessions_size();
  }

  std::string dir_;
  std::unique_ptr<ServerProcess> server_;
  std::shared_ptr<grpc::Channel> channel_;
  std::unique_ptr<v1::SlamService::Stub> stub_;
};

TEST_F(MapServerTest, MapsAreCreatedListedReadAndRefusedPrecisely) {
  v1::Map office;
  ASSERT_TRUE(CreateMap("office", &office).ok());
  EXPECT_EQ(office.name(), "office");
  EXPECT_EQ(office.revision(), 0u);
  EXPECT_GT(office.created_at_unix(), 0);
  ASSERT_TRUE(CreateMap("lab-2").ok());

  grpc::Status status = CreateMap("office");
  EXPECT_EQ(status.error_code(), grpc::StatusCode::ALREADY_EXISTS) << status.error_message();
  for (const std::string& bad :
       {std::string(), std::string("a b"), std::string(65, 'm'), std::string("-x")}) {
    status = CreateMap(bad);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << bad;
    EXPECT_NE(status.error_message().find("map name"), std::string::npos) << status.error_message();
  }
  // Not UTF-8: the request does not parse as the message (a string field), which says so.
  EXPECT_EQ(CreateMap("caf\xff").error_code(), grpc::StatusCode::INVALID_ARGUMENT);

  v1::ListMapsResponse listed;
  ASSERT_TRUE(stub_->ListMaps(MapCtx().get(), {}, &listed).ok());
  ASSERT_EQ(listed.maps_size(), 2);
  EXPECT_EQ(listed.maps(0).name(), "lab-2");
  EXPECT_EQ(listed.maps(1).name(), "office");

  v1::Map got;
  EXPECT_EQ(GetMapInfo("cellar", &got).error_code(), grpc::StatusCode::NOT_FOUND);
  v1::DeleteMapResponse deleted;
  EXPECT_EQ(DeleteMap("cellar", false, &deleted).error_code(), grpc::StatusCode::NOT_FOUND);
  v1::MapOccupancyGrid grid;
  status = MapGrid("office", &grid);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION) << status.error_message();
  EXPECT_EQ(MapGrid("cellar", &grid).error_code(), grpc::StatusCode::NOT_FOUND);

  ASSERT_TRUE(DeleteMap("lab-2", false, &deleted).ok());
  EXPECT_EQ(deleted.map().name(), "lab-2");
  EXPECT_EQ(GetMapInfo("lab-2", &got).error_code(), grpc::StatusCode::NOT_FOUND);
}

TEST_F(MapServerTest, OnlyLaserMappingSessionsJoinAndNothingIsStoredWhenRefused) {
  ASSERT_TRUE(CreateMap("office").ok());
  v1::Session session;
  grpc::Status status = Join("r1", "cellar", &session);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::NOT_FOUND) << status.error_message();
  status = Join("r1", "bad name", &session);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();

  v1::CreateSessionRequest no_closure = TestSessionRequest("r1");
  no_closure.set_map("office");
  no_closure.mutable_laser()->mutable_params()->set_loop_closure(false);
  status = stub_->CreateSession(MapCtx().get(), no_closure, &session);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT);
  EXPECT_NE(status.error_message().find("loop_closure"), std::string::npos);

  v1::CreateSessionRequest localize = TestSessionRequest("r1");
  localize.set_map("office");
  localize.mutable_laser()->mutable_localize()->set_map_session_id("whatever");
  status = stub_->CreateSession(MapCtx().get(), localize, &session);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();

  v1::CreateSessionRequest visual;
  visual.set_robot_id("r1");
  visual.set_map("office");
  visual.mutable_visual();
  status = stub_->CreateSession(MapCtx().get(), visual, &session);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();

  EXPECT_EQ(SessionCount(), 0);  // no refused session was stored
  v1::Map office;
  ASSERT_TRUE(GetMapInfo("office", &office).ok());
  EXPECT_EQ(office.trajectories_size(), 0);
  EXPECT_EQ(office.revision(), 0u);
}

TEST_F(MapServerTest, TheFirstRobotDefinesTheMapFrameTheSecondIsNotYetInTheMap) {
  ASSERT_TRUE(CreateMap("office").ok());
  v1::Session first, second;
  ASSERT_TRUE(Join("r1", "office", &first).ok());
  EXPECT_EQ(first.map(), "office");
  ASSERT_TRUE(Join("r2", "office", &second).ok());

  v1::Map office;
  ASSERT_TRUE(GetMapInfo("office", &office).ok());
  EXPECT_EQ(office.revision(), 2u);
  ASSERT_EQ(office.trajectories_size(), 2);
  EXPECT_EQ(office.trajectories(0).session_id(), first.session_id());
  EXPECT_EQ(office.trajectories(0).robot_id(), "r1");
  EXPECT_TRUE(office.trajectories(0).tied_in());
  EXPECT_EQ(office.trajectories(0).state(), v1::Session::OPEN);
  EXPECT_EQ(office.trajectories(1).session_id(), second.session_id());
  EXPECT_FALSE(office.trajectories(1).tied_in());

  // The first robot's answers carry its map-frame pose: its own frame is the map frame.
  grpc::Status status;
  std::vector<v1::SlamUpdate> answers = StreamInto(stub_.get(), first.session_id(), MapDrive(0, 8),
                                                   &status);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_GE(answers.size(), 4u);
  for (const v1::SlamUpdate& update : answers) {
    ASSERT_TRUE(update.has_map_pose());
    EXPECT_EQ(update.map_pose().map(), "office");
    EXPECT_TRUE(update.map_pose().tied_in());
    EXPECT_EQ(update.map_pose().map_revision(), 2u);
    EXPECT_NEAR(update.map_pose().pose().x(), update.pose().x(), 1e-12);
    EXPECT_NEAR(update.map_pose().pose().y(), update.pose().y(), 1e-12);
    EXPECT_NEAR(update.map_pose().pose().theta(), update.pose().theta(), 1e-12);
  }
  // The second is "not yet in the map": no map-frame pose.
  answers = StreamInto(stub_.get(), second.session_id(), MapDrive(0, 8), &status);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_GE(answers.size(), 4u);
  for (const v1::SlamUpdate& update : answers) {
    ASSERT_TRUE(update.has_map_pose());
    EXPECT_FALSE(update.map_pose().tied_in());
    EXPECT_FALSE(update.map_pose().has_pose());
  }

  // Sessions say which map they are in.
  v1::ListSessionsResponse listed;
  ASSERT_TRUE(stub_->ListSessions(MapCtx().get(), {}, &listed).ok());
  for (const v1::Session& s : listed.sessions()) EXPECT_EQ(s.map(), "office") << s.session_id();

  // The map's grid is the first trajectory's grid, cell for cell.
  v1::MapOccupancyGrid map_grid;
  ASSERT_TRUE(MapGrid("office", &map_grid).ok());
  EXPECT_EQ(map_grid.revision(), 2u);
  ASSERT_EQ(map_grid.session_ids_size(), 1);
  EXPECT_EQ(map_grid.session_ids(0), first.session_id());
  EXPECT_EQ(map_grid.untied_trajectories(), 1u);
  v1::GetOccupancyGridRequest request;
  request.set_session_id(first.session_id());
  v1::OccupancyGrid session_grid;
  ASSERT_TRUE(stub_->GetOccupancyGrid(MapCtx().get(), request, &session_grid).ok());
  EXPECT_EQ(map_grid.grid().width(), session_grid.width());
  EXPECT_EQ(map_grid.grid().height(), session_grid.height());
  EXPECT_GT(map_grid.grid().scans(), 0u);
  EXPECT_EQ(map_grid.grid().cells(), session_grid.cells());
}

TEST_F(MapServerTest, AMapInUseIsDeletedOnlyWithForceWhichDetachesItsSessions) {
  ASSERT_TRUE(CreateMap("office").ok());
  v1::Session first;
  ASSERT_TRUE(Join("r1", "office", &first).ok());
  v1::DeleteMapResponse deleted;
  grpc::Status status = DeleteMap("office", false, &deleted);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_NE(status.error_message().find("force"), std::string::npos) << status.error_message();

  ASSERT_TRUE(DeleteMap("office", true, &deleted).ok());
  EXPECT_EQ(deleted.detached_sessions(), 1u);
  EXPECT_EQ(deleted.map().trajectories_size(), 1);
  // The session goes on alone.
  std::vector<v1::SlamUpdate> answers =
      StreamInto(stub_.get(), first.session_id(), MapDrive(0, 5), &status);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_FALSE(answers.empty());
  for (const v1::SlamUpdate& update : answers) EXPECT_FALSE(update.has_map_pose());
  v1::GetMapRequest request;
  request.set_session_id(first.session_id());
  v1::SegmentMap segments;
  EXPECT_TRUE(stub_->GetMap(MapCtx().get(), request, &segments).ok());
}

TEST_F(MapServerTest, ADeletedSessionLeavesItsMapAndTheNextOneDefinesTheFrame) {
  ASSERT_TRUE(CreateMap("office").ok());
  v1::Session first, second;
  ASSERT_TRUE(Join("r1", "office", &first).ok());
  ASSERT_TRUE(Join("r2", "office", &second).ok());
  v1::DeleteSessionRequest request;
  request.set_session_id(first.session_id());
  request.set_force(true);
  v1::DeleteSessionResponse response;
  ASSERT_TRUE(stub_->DeleteSession(MapCtx().get(), request, &response).ok());
  EXPECT_EQ(response.session().map(), "office");
  v1::Map office;
  ASSERT_TRUE(GetMapInfo("office", &office).ok());
  EXPECT_EQ(office.revision(), 3u);
  ASSERT_EQ(office.trajectories_size(), 1);
  EXPECT_EQ(office.trajectories(0).session_id(), second.session_id());
  EXPECT_TRUE(office.trajectories(0).tied_in());
}

TEST_F(MapServerTest, AMapAndItsTrajectoriesSurviveARestart) {
  ASSERT_TRUE(CreateMap("office").ok());
  v1::Session first, second;
  ASSERT_TRUE(Join("r1", "office", &first).ok());
  ASSERT_TRUE(Join("r2", "office", &second).ok());
  grpc::Status status;
  ASSERT_FALSE(StreamInto(stub_.get(), first.session_id(), MapDrive(0, 6), &status).empty());
  ASSERT_TRUE(status.ok()) << status.error_message();
  v1::Map before;
  ASSERT_TRUE(GetMapInfo("office", &before).ok());

  Restart();

  v1::Map after;
  ASSERT_TRUE(GetMapInfo("office", &after).ok());
  EXPECT_EQ(after.revision(), before.revision());
  ASSERT_EQ(after.trajectories_size(), 2);
  for (int i = 0; i < 2; ++i) {
    EXPECT_EQ(after.trajectories(i).session_id(), before.trajectories(i).session_id());
    EXPECT_EQ(after.trajectories(i).robot_id(), before.trajectories(i).robot_id());
    EXPECT_EQ(after.trajectories(i).tied_in(), before.trajectories(i).tied_in());
  }
  EXPECT_GT(after.trajectories(0).scans_processed(), 0u);  // checkpointed at shutdown

  // The memberships were loaded at start-up: resumed sessions still answer in the map.
  std::vector<v1::SlamUpdate> answers =
      StreamInto(stub_.get(), first.session_id(), MapDrive(6, 4), &status);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_FALSE(answers.empty());
  for (const v1::SlamUpdate& update : answers) {
    ASSERT_TRUE(update.has_map_pose());
    EXPECT_TRUE(update.map_pose().tied_in());
  }
  answers = StreamInto(stub_.get(), second.session_id(), MapDrive(0, 4), &status);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_FALSE(answers.empty());
  for (const v1::SlamUpdate& update : answers) {
    ASSERT_TRUE(update.has_map_pose());
    EXPECT_FALSE(update.map_pose().tied_in());
  }
  v1::ListSessionsResponse listed;
  ASSERT_TRUE(stub_->ListSessions(MapCtx().get(), {}, &listed).ok());
  ASSERT_EQ(listed.sessions_size(), 2);
  for (const v1::Session& s : listed.sessions()) EXPECT_EQ(s.map(), "office");
}

// A tie stored by MapStore::TieTrajectory (as the tie worker stores one) is loaded at start-up
// and turns the session's poses into map-frame poses: origin * session pose.
TEST_F(MapServerTest, ATiedInTrajectorysAnswersAreInTheMapFrame) {
  ASSERT_TRUE(CreateMap("office").ok());
  v1::Session first, second;
  ASSERT_TRUE(Join("r1", "office", &first).ok());
  ASSERT_TRUE(Join("r2", "office", &second).ok());
  stub_.reset();
  channel_.reset();
  ASSERT_EQ(server_->Stop(SIGTERM), 0);
  {
    auto store = storage::OpenSqliteMapStore(dir_ + "/waymark.db");
    ASSERT_TRUE(store.ok()) << store.status();
    auto tied = (*store)->TieTrajectory("office", second.session_id(),
                                        storage::MapTie{1.0, -2.0, M_PI / 2}, "");
    ASSERT_TRUE(tied.ok()) << tied.status();
  }
  StartServer();
  grpc::Status status;
  std::vector<v1::SlamUpdate> answers =
      StreamInto(stub_.get(), second.session_id(), MapDrive(0, 6), &status);
  ASSERT_TRUE(status.ok()) << status.error_message();
  ASSERT_GE(answers.size(), 3u);
  for (const v1::SlamUpdate& update : answers) {
    ASSERT_TRUE(update.map_pose().tied_in());
    EXPECT_EQ(update.map_pose().map_revision(), 3u);
    // Rotated a quarter turn and moved by (1, -2): (x, y, t) -> (1 - y, -2 + x, t + pi/2).
    EXPECT_NEAR(update.map_pose().pose().x(), 1.0 - update.pose().y(), 1e-9);
    EXPECT_NEAR(update.map_pose().pose().y(), -2.0 + update.pose().x(), 1e-9);
    EXPECT_NEAR(std::remainder(update.map_pose().pose().theta() - update.pose().theta() - M_PI / 2,
                               2 * M_PI),
                0.0, 1e-9);
  }
  // Two trajectories tied in: one grid of both, in the map frame.
  v1::MapOccupancyGrid grid;
  ASSERT_TRUE(MapGrid("office", &grid).ok());
  EXPECT_EQ(grid.session_ids_size(), 2);
  EXPECT_EQ(grid.untied_trajectories(), 0u);
  EXPECT_GT(grid.grid().width() * grid.grid().height(), 0u);
}

// Two robots that mapped the same walls, the second tied in where the first is (origin 0): the
// map's segment map holds each wall once, the second trajectory's sightings fused into the
// first's. Before any robot is tied in, there is no segment map to give.
TEST_F(MapServerTest, AWallTwoRobotsMappedIsOneSegmentOfTheMap) {
  ASSERT_TRUE(CreateMap("office").ok());
  v1::MapSegmentMap segments;
  EXPECT_EQ(MapSegments("office", &segments).error_code(), grpc::StatusCode::FAILED_PRECONDITION);
  EXPECT_EQ(MapSegments("no-such-map", &segments).error_code(), grpc::StatusCode::NOT_FOUND);
  v1::Session first, second;
  ASSERT_TRUE(Join("r1", "office", &first).ok());
  ASSERT_TRUE(Join("r2", "office", &second).ok());
  grpc::Status status;
  StreamInto(stub_.get(), first.session_id(), MapDrive(0, 8), &status);
  ASSERT_TRUE(status.ok()) << status.error_message();
  StreamInto(stub_.get(), second.session_id(), MapDrive(0, 8), &status);
  ASSERT_TRUE(status.ok()) << status.error_message();
  const int own_first = SessionSegments(first.session_id());
  const int own_second = SessionSegments(second.session_id());
  ASSERT_GT(own_first, 2);
  ASSERT_GT(own_second, 2);

  // Only the first is in the map: its segments, as its session has them.
  ASSERT_TRUE(MapSegments("office", &segments).ok());
  ASSERT_EQ(segments.session_ids_size(), 1);
  EXPECT_EQ(segments.untied_trajectories(), 1u);
  EXPECT_EQ(segments.segments_size(), own_first);
  EXPECT_EQ(segments.fused_segments(), 0u);
  for (const v1::MapSegment& s : segments.segments()) EXPECT_GT(s.last_seen_scan(), 0u);

  stub_.reset();
  channel_.reset();
  ASSERT_EQ(server_->Stop(SIGTERM), 0);
  {
    auto store = storage::OpenSqliteMapStore(dir_ + "/waymark.db");
    ASSERT_TRUE(store.ok()) << store.status();
    ASSERT_TRUE((*store)->TieTrajectory("office", second.session_id(),
                                        storage::MapTie{0.0, 0.0, 0.0}, "")
                    .ok());
  }
  StartServer();
  ASSERT_TRUE(MapSegments("office", &segments).ok());
  EXPECT_EQ(segments.session_ids_size(), 2);
  EXPECT_EQ(segments.untied_trajectories(), 0u);
  EXPECT_GT(segments.fused_segments(), 0u);
  EXPECT_EQ(segments.segments_size() + static_cast<int>(segments.fused_segments()),
            own_first + own_second);
  // The same drive twice: most walls are the first robot's, seen again.
  EXPECT_LE(segments.segments_size(), own_first + own_second / 2);
}

// The command lines: `waymark map ...` and a log replayed as two robots into one map.
TEST_F(MapServerTest, MapCommandsAndReplayIntoAMap) {
  using testing::RunWaymark;
  const std::string address = server_->address();
  testing::ScopedTempDir temp;
  const std::filesystem::path log = temp.Make("robots.clf");
  std::ofstream(log) << testing::MakeLogWithStamps([] {
    std::vector<double> stamps;
    for (int i = 0; i < 60; ++i) stamps.push_back(1000 + 0.2 * i);
    return stamps;
  }());

  testing::CliResult created = RunWaymark(address, {"map", "create", "office"});
  ASSERT_EQ(created.code, 0) << created.err;
  EXPECT_NE(created.out.find("created map office"), std::string::npos) << created.out;
  testing::CliResult again = RunWaymark(address, {"map", "create", "office"});
  EXPECT_NE(again.code, 0);
  EXPECT_NE(again.err.find("ALREADY_EXISTS"), std::string::npos) << again.err;
  testing::CliResult bad = RunWaymark(address, {"map", "create", "a/b"});
  EXPECT_NE(bad.code, 0);
  EXPECT_NE(bad.err.find("INVALID_ARGUMENT"), std::string::npos) << bad.err;
  testing::CliResult empty_grid = RunWaymark(address, {"map", "grid", "office"});
  EXPECT_NE(empty_grid.code, 0);
  EXPECT_NE(empty_grid.err.find("no trajectory yet"), std::string::npos) << empty_grid.err;

  // Two robots: the first 40 scans and the last 30 (10 shared).
  testing::CliResult one = RunWaymark(
      address, {"--json", "slam", "replay", log.string(), "--map", "office", "--scans", "0:40",
                "--robot", "r1", "--out", temp.Make("r1").string()});
  ASSERT_EQ(one.code, 0) << one.err;
  const nlohmann::json first = one.Json();
  EXPECT_EQ(first["scans_sent"], 40);
  EXPECT_EQ(first["scan_slice"], "0:40");
  EXPECT_EQ(first["shared_map"]["name"], "office");
  EXPECT_EQ(first["shared_map"]["trajectory"], 1);
  EXPECT_EQ(first["shared_map"]["tied_in"], true);
  EXPECT_EQ(first["shared_map"]["map_pose_tied"], first["shared_map"]["map_pose_answers"]);
  EXPECT_GT(first["shared_map"]["map_pose_answers"].get<int>(), 0);
  testing::CliResult two = RunWaymark(
      address, {"--json", "slam", "replay", log.string(), "--map", "office", "--scans", "30:",
                "--robot", "r2", "--out", temp.Make("r2").string()});
  ASSERT_EQ(two.code, 0) << two.err;
  const nlohmann::json second = two.Json();
  EXPECT_EQ(second["scans_sent"], 30);
  EXPECT_EQ(second["shared_map"]["trajectory"], 2);
  EXPECT_EQ(second["shared_map"]["tied_in"], false);
  EXPECT_EQ(second["shared_map"]["map_pose_tied"], 0);
  testing::CliResult slice = RunWaymark(address, {"slam", "replay", log.string(), "--scans", "9"});
  EXPECT_NE(slice.code, 0);
  EXPECT_NE(slice.err.find("--scans"), std::string::npos) << slice.err;

  testing::CliResult sessions = RunWaymark(address, {"slam", "list"});
  ASSERT_EQ(sessions.code, 0) << sessions.err;
  EXPECT_NE(sessions.out.find("in map"), std::string::npos) << sessions.out;
  EXPECT_NE(sessions.out.find("office"), std::string::npos) << sessions.out;

  testing::CliResult shown = RunWaymark(address, {"map", "show", "office"});
  ASSERT_EQ(shown.code, 0) << shown.err;
  EXPECT_NE(shown.out.find("2 trajectories (1 tied in, 1 not yet in the map), revision 2"),
            std::string::npos)
      << shown.out;
  testing::CliResult shown_json = RunWaymark(address, {"--json", "map", "show", "office"});
  ASSERT_EQ(shown_json.code, 0) << shown_json.err;
  EXPECT_EQ(shown_json.Json()["trajectories"].size(), 2u);
  EXPECT_EQ(shown_json.Json()["trajectories"][0]["robot_id"], "r1");
  testing::CliResult listed = RunWaymark(address, {"--json", "map", "list"});
  ASSERT_EQ(listed.code, 0) << listed.err;
  EXPECT_EQ(listed.Json()["maps"][0]["name"], "office");

  const std::filesystem::path grid_dir = temp.path() / "grid";
  testing::CliResult grid =
      RunWaymark(address, {"--json", "map", "grid", "office", "--out", grid_dir.string()});
  ASSERT_EQ(grid.code, 0) << grid.err;
  EXPECT_EQ(grid.Json()["untied_trajectories"], 1);
  EXPECT_GT(grid.Json()["width"].get<int>(), 0);
  // Beside the grid, the map's segment map: the tied-in robot's segments, none fused.
  EXPECT_GT(grid.Json()["segments"].get<int>(), 0);
  EXPECT_EQ(grid.Json()["fused_segments"], 0);
  for (const char* file : {"map.pgm", "map.yaml", "occupancy.png", "map.svg", "map.png"}) {
    EXPECT_TRUE(std::filesystem::exists(grid_dir / file)) << file;
  }
  // The map's grid is the first robot's session grid, written the same way.
  EXPECT_EQ(testing::ReadAll(grid_dir / "map.pgm"), testing::ReadAll(temp.path() / "r1" / "map.pgm"));

  // Poses in the map frame: the first robot's are its own (tied in at the origin); the second
  // is not yet in the map.
  const std::string r1_id = shown_json.Json()["trajectories"][0]["session_id"];
  const std::string r2_id = shown_json.Json()["trajectories"][1]["session_id"];
  testing::CliResult own = RunWaymark(address, {"slam", "trajectory", r1_id});
  testing::CliResult in_map = RunWaymark(address, {"slam", "trajectory", r1_id, "--frame", "map"});
  ASSERT_EQ(in_map.code, 0) << in_map.err;
  EXPECT_EQ(in_map.out, own.out);
  testing::CliResult untied = RunWaymark(address, {"slam", "trajectory", r2_id, "--frame", "map"});
  EXPECT_NE(untied.code, 0);
  EXPECT_NE(untied.err.find("not yet in map"), std::string::npos) << untied.err;

  // A third robot with a known start is tied in there at once; its poses move with it.
  testing::CliResult three = RunWaymark(
      address, {"--json", "slam", "replay", log.string(), "--map", "office", "--scans", "0:20",
                "--initial-pose", "2,-1,1.5707963267948966", "--robot", "r3", "--out",
                temp.Make("r3").string()});
  ASSERT_EQ(three.code, 0) << three.err;
  EXPECT_EQ(three.Json()["shared_map"]["tied_in"], true);
  EXPECT_EQ(three.Json()["shared_map"]["map_pose_tied"], three.Json()["shared_map"]["map_pose_answers"]);
  const nlohmann::json with_three = RunWaymark(address, {"--json", "map", "show", "office"}).Json();
  ASSERT_EQ(with_three["trajectories"].size(), 3u);
  EXPECT_EQ(with_three["trajectories"][2]["origin"]["x"], 2.0);
  EXPECT_EQ(with_three["trajectories"][2]["origin"]["y"], -1.0);
  const std::string r3_id = with_three["trajectories"][2]["session_id"];
  testing::CliResult r3_map = RunWaymark(address, {"slam", "trajectory", r3_id, "--frame", "map"});
  ASSERT_EQ(r3_map.code, 0) << r3_map.err;
  // Its first pose is its start: (2, -1) in the map frame.
  const std::string first_line = r3_map.out.substr(r3_map.out.find('\n') + 1);
  EXPECT_NE(first_line.find(" 2.000000 -1.000000 "), std::string::npos) << r3_map.out;
  // Two trajectories tied in (r1 at the origin, r3 at its start): one grid of both.
  testing::CliResult merged =
      RunWaymark(address, {"--json", "map", "grid", "office", "--out", grid_dir.string()});
  ASSERT_EQ(merged.code, 0) << merged.err;
  EXPECT_EQ(merged.Json()["untied_trajectories"], 1);
  testing::CliResult lonely = RunWaymark(
      address, {"slam", "replay", log.string(), "--scans", "0:5", "--initial-pose", "0,0,0"});
  EXPECT_NE(lonely.code, 0);
  EXPECT_NE(lonely.err.find("--initial-pose needs"), std::string::npos) << lonely.err;

  // Every session is closed: the map is not in use.
  testing::CliResult deleted = RunWaymark(address, {"--json", "map", "delete", "office"});
  ASSERT_EQ(deleted.code, 0) << deleted.err;
  EXPECT_EQ(deleted.Json()["map"]["trajectories"].size(), 3u);
  testing::CliResult gone = RunWaymark(address, {"map", "show", "office"});
  EXPECT_NE(gone.code, 0);
  EXPECT_NE(gone.err.find("NOT_FOUND"), std::string::npos) << gone.err;
}

}  // namespace
}  // namespace waymark
