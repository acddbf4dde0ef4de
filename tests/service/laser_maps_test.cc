// Laser maps in the registry (engine + SQLite, no gRPC): the occupancy grid of a session, live and
// after a restart, imported maps, and localization sessions on a closed map, with the precise
// refusals a robot engineer needs (unknown map, visual session, open session, no scans kept).

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "gtest/gtest.h"
#include "server/service/slam/slam_registry.h"
#include "storage/slam_store.h"
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

class LaserMapsTest : public ::testing::Test {
 protected:
  std::unique_ptr<SlamRegistry> MakeRegistry() {
    SlamRegistryOptions options;
    options.workers = 2;
    options.queue_capacity = 1000;  // a drive is submitted at once, without waiting for answers
    auto store = storage::OpenSqliteSlamStore(db_path_);
    EXPECT_TRUE(store.ok()) << store.status();
    auto registry = SlamRegistry::Create(std::move(*store), options);
    EXPECT_TRUE(registry.ok()) << registry.status();
    return std::move(*registry);
  }

  // Drives from x = -1.5 to +1.5 m and back in 0.1 m steps (odometry before each scan); returns
  // the answers.
  static std::vector<v1::SlamUpdate> DriveAcross(SlamRegistry& registry, const std::string& id,
                                                 double t0 = 0.0) {
    Answers answers;
    auto stream = registry.OpenStream(id, answers.Sink());
    EXPECT_TRUE(stream.ok()) << stream.status();
    if (!stream.ok()) return {};
    uint64_t seq = 1;
    for (int k = 0; k <= 60; ++k) {
      const double x = k <= 30 ? -1.5 + 0.1 * k : 1.5 - 0.1 * (k - 30);
      const double t = t0 + 1.0 + k;
      EXPECT_OK((*stream)->Submit(Odom(seq++, t, x, 0.3, 0)));
      EXPECT_OK((*stream)->Submit(RoomScan(seq++, t, x, 0.3, 0)));
    }
    (*stream)->Close();
    return answers.Get();
  }

  // A closed mapping session of the room; its id.
  std::string MappedRoom(SlamRegistry& registry) {
    v1::CreateSessionRequest request = TestSessionRequest("mapper");
    request.mutable_laser()->mutable_laser_pose();  // at the robot's origin
    auto session = registry.CreateSession(request);
    EXPECT_TRUE(session.ok()) << session.status();
    DriveAcross(registry, session->session_id());
    EXPECT_TRUE(registry.CloseSession(session->session_id()).ok());
    return session->session_id();
  }

  static v1::CreateSessionRequest LocalizeRequest(const std::string& map) {
    v1::CreateSessionRequest request = TestSessionRequest("localizer");
    request.mutable_laser()->mutable_localize()->set_map_session_id(map);
    return request;
  }

  TempDir dir_;
  std::string db_path_ = dir_.File("slam.db");
};

// Cells of the grid at world (x, y).
int CellAt(const v1::OccupancyGrid& grid, double x, double y) {
  const int cx = static_cast<int>(std::floor((x - grid.origin().x()) / grid.resolution()));
  const int cy = static_cast<int>(std::floor((y - grid.origin().y()) / grid.resolution()));
  if (cx < 0 || cy < 0 || cx >= static_cast<int>(grid.width()) ||
      cy >= static_cast<int>(grid.height())) {
    return -2;
  }
  return static_cast<std::int8_t>(grid.cells()[cy * grid.width() + cx]);
}

TEST_F(LaserMapsTest, TheGridShowsTheRoomLiveAfterClosingAndAfterARestart) {
  std::string id;
  v1::OccupancyGrid live;
  {
    auto registry = MakeRegistry();
    ASSERT_OK_AND_ASSIGN(v1::Session session, registry->CreateSession(TestSessionRequest("r1")));
    id = session.session_id();
    DriveAcross(*registry, id);
    ASSERT_OK_AND_ASSIGN(live, registry->GetOccupancyGrid(id, std::nullopt));
    EXPECT_EQ(live.resolution(), 0.05);
    EXPECT_GT(live.scans(), 5u);
    ASSERT_EQ(live.cells().size(), static_cast<size_t>(live.width()) * live.height());
    // The map frame is the first pose (x = -1.5, y = 0.3): the walls at +-4 m in the world are at
    // x = -2.5 and 5.5, y = -4.3 and 3.7 in it.
    EXPECT_LE(CellAt(live, 1.5, 0.0), 19);  // free in the middle
    int wall = -1;
    for (double dx : {-0.05, 0.0, 0.05}) wall = std::max(wall, CellAt(live, 5.5 + dx, 0.0));
    EXPECT_GE(wall, 65);
    EXPECT_EQ(CodeOf(registry->GetOccupancyGrid(id, 0.001)), absl::StatusCode::kInvalidArgument);
    EXPECT_EQ(CodeOf(registry->GetOccupancyGrid("nope", std::nullopt)),
              absl::StatusCode::kNotFound);
    ASSERT_OK(registry->Shutdown());  // checkpoints the open session, graph included
  }
  auto registry = MakeRegistry();
  ASSERT_OK_AND_ASSIGN(v1::OccupancyGrid resumed, registry->GetOccupancyGrid(id, std::nullopt));
  EXPECT_EQ(resumed.width(), live.width());
  EXPECT_EQ(resumed.height(), live.height());
  EXPECT_EQ(resumed.cells(), live.cells());
  ASSERT_OK(registry->CloseSession(id).status());
  ASSERT_OK_AND_ASSIGN(v1::OccupancyGrid closed, registry->GetOccupancyGrid(id, 0.1));
  EXPECT_NEAR(closed.width(), live.width() / 2.0, 4.0);  // the margins are 2 cells either way
  ASSERT_OK_AND_ASSIGN(v1::SegmentMap map, registry->GetMap(id));
  EXPECT_GT(map.graph_nodes(), 5u);
}

TEST_F(LaserMapsTest, ThePapersMethodAloneKeepsNoScansAndSaysSo) {
  auto registry = MakeRegistry();
  v1::CreateSessionRequest request = TestSessionRequest("r1");
  request.mutable_laser()->mutable_params()->set_loop_closure(false);
  ASSERT_OK_AND_ASSIGN(v1::Session session, registry->CreateSession(request));
  EXPECT_FALSE(session.laser().params().loop_closure());
  ASSERT_OK_AND_ASSIGN(v1::Session defaults, registry->CreateSession(TestSessionRequest("r2")));
  EXPECT_TRUE(defaults.laser().params().loop_closure());  // the effective config says it
  DriveAcross(*registry, session.session_id());
  const absl::StatusOr<v1::OccupancyGrid> grid =
      registry->GetOccupancyGrid(session.session_id(), std::nullopt);
  EXPECT_EQ(CodeOf(grid), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(grid.status().message().find("loop closure is off"), std::string::npos)
      << grid.status();
  // ... and cannot be localized on.
  ASSERT_OK(registry->CloseSession(session.session_id()).status());
  const absl::StatusOr<v1::Session> localize =
      registry->CreateSession(LocalizeRequest(session.session_id()));
  EXPECT_EQ(CodeOf(localize), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(localize.status().message().find("keeps no scans"), std::string::npos)
      << localize.status();
}

// Pruning (lifelong mapping) is on unless a session turns it off, and the session says which.
TEST_F(LaserMapsTest, PruningIsOnByDefaultAndASessionMayTurnItOff) {
  auto registry = MakeRegistry();
  v1::CreateSessionRequest request = TestSessionRequest("r1");
  request.mutable_laser()->mutable_params()->set_prune_redundant_submaps(false);
  ASSERT_OK_AND_ASSIGN(v1::Session session, registry->CreateSession(request));
  EXPECT_FALSE(session.laser().params().prune_redundant_submaps());
  ASSERT_OK_AND_ASSIGN(v1::Session defaults, registry->CreateSession(TestSessionRequest("r2")));
  ASSERT_TRUE(defaults.laser().params().has_prune_redundant_submaps());
  EXPECT_TRUE(defaults.laser().params().prune_redundant_submaps());
  DriveAcross(*registry, session.session_id());
  ASSERT_OK(registry->CloseSession(session.session_id()).status());
  ASSERT_OK_AND_ASSIGN(v1::SegmentMap map, registry->GetMap(session.session_id()));
  EXPECT_GT(map.graph_nodes(), 5u);
  EXPECT_EQ(map.pruned_nodes(), 0u);
}

TEST_F(LaserMapsTest, ARobotLocalizesOnAClosedMapFromAKnownStart) {
  auto registry = MakeRegistry();
  const std::string map = MappedRoom(*registry);
  v1::CreateSessionRequest request = LocalizeRequest(map);
  // The robot starts at world (0, -1): in the map's frame (origin at world (-1.5, 0.3)) that is
  // (1.5, -1.3); the initial pose is 0.3 m off.
  v1::Pose2D* initial = request.mutable_laser()->mutable_localize()->mutable_initial_pose();
  initial->set_x(1.7);
  initial->set_y(-1.1);
  ASSERT_OK_AND_ASSIGN(v1::Session session, registry->CreateSession(request));
  EXPECT_EQ(session.laser().localize().initial_sigma_xy(), 0.5);  // defaults echoed

  Answers answers;
  ASSERT_OK_AND_ASSIGN(auto stream, registry->OpenStream(session.session_id(), answers.Sink()));
  uint64_t seq = 1;
  for (int k = 0; k < 15; ++k) {
    const double y = -1.0 + 0.1 * k;
    ASSERT_OK((*stream).Submit(Odom(seq++, 1.0 + k, 0.0, y, 0.0)));
    ASSERT_OK((*stream).Submit(RoomScan(seq++, 1.0 + k, 0.0, y, 0.0)));
  }
  stream->Close();
  const std::vector<v1::SlamUpdate> updates = answers.Get();
  ASSERT_EQ(updates.size(), 15u);
  // Dead reckoning from the given start until five scans 0.25 m apart can be matched: localized
  // from the fifth on, never by a global search.
  EXPECT_FALSE(updates.front().localization().localized());
  EXPECT_EQ(updates.front().localization().state(), v1::LocalizationStatus::FROM_START);
  for (const v1::SlamUpdate& u : updates) EXPECT_FALSE(u.localization().global_search());
  EXPECT_TRUE(updates.back().localization().localized());
  EXPECT_EQ(updates.back().localization().state(), v1::LocalizationStatus::TRACKING);
  EXPECT_GE(updates.back().localization().fixes(), 1u);
  // Each fix carries its confidence: a score, and a rival below it (0 when none comes near).
  EXPECT_GT(updates.back().localization().score(), 0.55);
  EXPECT_LT(updates.back().localization().rival_ratio(), 1.0);
  // Odometry started at the robot's own origin; the answers are in the map's frame.
  EXPECT_NEAR(updates.back().pose().x(), 1.5, 0.05);
  EXPECT_NEAR(updates.back().pose().y(), -1.3 + 1.4, 0.05);
  // The trajectory is in the map's frame too, not the odometry's (x = 0 there).
  ASSERT_OK_AND_ASSIGN(v1::Trajectory trajectory, registry->GetTrajectory(session.session_id()));
  ASSERT_EQ(trajectory.poses_size(), 15);
  EXPECT_NEAR(trajectory.poses(14).pose().x(), 1.5, 0.05);
  EXPECT_NEAR(trajectory.poses(0).pose().y(), -1.3, 0.05);

  // It survives a restart: the map is found again and the session goes on localized.
  ASSERT_OK(registry->Shutdown());
  registry = MakeRegistry();
  Answers more;
  ASSERT_OK_AND_ASSIGN(auto resumed, registry->OpenStream(session.session_id(), more.Sink()));
  ASSERT_OK((*resumed).Submit(Odom(100, 20.0, 0.0, 0.5, 0.0)));
  ASSERT_OK((*resumed).Submit(RoomScan(101, 20.0, 0.0, 0.5, 0.0)));
  resumed->Close();
  ASSERT_EQ(more.Get().size(), 1u);
  EXPECT_TRUE(more.Get().front().localization().localized());
  EXPECT_NEAR(more.Get().front().pose().y(), -1.3 + 1.5, 0.05);
}

TEST_F(LaserMapsTest, LocalizingOnAMapThatCannotBeOneIsRefusedPrecisely) {
  auto registry = MakeRegistry();
  const auto refused = [&](const std::string& map, absl::StatusCode code, const std::string& says) {
    const absl::StatusOr<v1::Session> s = registry->CreateSession(LocalizeRequest(map));
    EXPECT_EQ(CodeOf(s), code) << map << ": " << s.status();
    EXPECT_NE(s.status().message().find(says), std::string::npos) << s.status();
  };
  refused("0123456789abcdef0123456789abcdef", absl::StatusCode::kNotFound, "not found");
  ASSERT_OK_AND_ASSIGN(v1::Session open, registry->CreateSession(TestSessionRequest("r1")));
  refused(open.session_id(), absl::StatusCode::kFailedPrecondition, "still open for writing");
  const std::string map = MappedRoom(*registry);
  ASSERT_OK_AND_ASSIGN(v1::Session localizing, registry->CreateSession(LocalizeRequest(map)));
  ASSERT_OK(registry->CloseSession(localizing.session_id()).status());
  refused(localizing.session_id(), absl::StatusCode::kFailedPrecondition,
          "is itself a localization session");
  refused("", absl::StatusCode::kInvalidArgument, "map_session_id");

  v1::CreateSessionRequest bad_sigma = LocalizeRequest(map);
  bad_sigma.mutable_laser()->mutable_localize()->set_initial_sigma_xy(-1);
  EXPECT_EQ(CodeOf(registry->CreateSession(bad_sigma)), absl::StatusCode::kInvalidArgument);
  v1::CreateSessionRequest bad_pose = LocalizeRequest(map);
  bad_pose.mutable_laser()->mutable_localize()->mutable_initial_pose()->set_x(NAN);
  EXPECT_EQ(CodeOf(registry->CreateSession(bad_pose)), absl::StatusCode::kInvalidArgument);

  // A visual session has no laser map.
  v1::CreateSessionRequest visual;
  visual.set_robot_id("cam");
  v1::CameraIntrinsics* camera = visual.mutable_visual()->mutable_camera();
  camera->set_fx(300);
  camera->set_fy(300);
  camera->set_cx(160);
  camera->set_cy(120);
  camera->set_width(320);
  camera->set_height(240);
  ASSERT_OK_AND_ASSIGN(v1::Session camera_session, registry->CreateSession(visual));
  ASSERT_OK(registry->CloseSession(camera_session.session_id()).status());
  refused(camera_session.session_id(), absl::StatusCode::kFailedPrecondition,
          "is a visual session");
  EXPECT_EQ(CodeOf(registry->GetOccupancyGrid(camera_session.session_id(), std::nullopt)),
            absl::StatusCode::kFailedPrecondition);
}

TEST_F(LaserMapsTest, AnImportedGridIsAClosedMapToLocalizeOn) {
  auto registry = MakeRegistry();
  const std::string map = MappedRoom(*registry);
  ASSERT_OK_AND_ASSIGN(v1::OccupancyGrid grid, registry->GetOccupancyGrid(map, std::nullopt));
  v1::ImportMapRequest request;
  request.set_robot_id("localizer");
  request.set_name("the room, from map.pgm");
  *request.mutable_grid() = grid;
  ASSERT_OK_AND_ASSIGN(v1::Session imported, registry->ImportMap(request));
  EXPECT_EQ(imported.state(), v1::Session::CLOSED);
  EXPECT_EQ(imported.kind(), "laser");
  ASSERT_OK_AND_ASSIGN(v1::OccupancyGrid back,
                       registry->GetOccupancyGrid(imported.session_id(), std::nullopt));
  EXPECT_EQ(back.cells(), grid.cells());
  EXPECT_EQ(back.origin().x(), grid.origin().x());
  EXPECT_EQ(back.width(), grid.width());

  v1::CreateSessionRequest localize = LocalizeRequest(imported.session_id());
  v1::Pose2D* initial = localize.mutable_laser()->mutable_localize()->mutable_initial_pose();
  initial->set_x(1.5);
  initial->set_y(-0.3);
  ASSERT_OK_AND_ASSIGN(v1::Session session, registry->CreateSession(localize));
  Answers answers;
  ASSERT_OK_AND_ASSIGN(auto stream, registry->OpenStream(session.session_id(), answers.Sink()));
  // Five scans 0.3 m apart along -y from world (0, 0), the map's (1.5, -0.3).
  for (int k = 0; k < 5; ++k) {
    ASSERT_OK((*stream).Submit(Odom(2 * k + 1, 1.0 + k, 0.0, -0.3 * k, 0.0)));
    ASSERT_OK((*stream).Submit(RoomScan(2 * k + 2, 1.0 + k, 0.0, -0.3 * k, 0.0)));
  }
  stream->Close();
  ASSERT_EQ(answers.Get().size(), 5u);
  const v1::SlamUpdate last = answers.Get().back();
  EXPECT_TRUE(last.localization().localized());
  EXPECT_NEAR(last.pose().x(), 1.5, 0.08);
  EXPECT_NEAR(last.pose().y(), -0.3 - 1.2, 0.08);

  // Bad grids are refused naming the field, and nothing is stored.
  ASSERT_OK_AND_ASSIGN(v1::ListSessionsResponse before, registry->ListSessions(""));
  v1::ImportMapRequest bad = request;
  bad.mutable_grid()->mutable_cells()->pop_back();
  EXPECT_EQ(CodeOf(registry->ImportMap(bad)), absl::StatusCode::kInvalidArgument);
  bad = request;
  bad.mutable_grid()->set_resolution(0);
  EXPECT_EQ(CodeOf(registry->ImportMap(bad)), absl::StatusCode::kInvalidArgument);
  bad = request;
  bad.mutable_grid()->set_cells(std::string(grid.cells().size(), '\0'));  // all free
  EXPECT_EQ(CodeOf(registry->ImportMap(bad)), absl::StatusCode::kInvalidArgument);
  bad = request;
  bad.mutable_grid()->mutable_cells()->at(0) = static_cast<char>(101);
  EXPECT_EQ(CodeOf(registry->ImportMap(bad)), absl::StatusCode::kInvalidArgument);
  bad = request;
  bad.set_robot_id("");
  EXPECT_EQ(CodeOf(registry->ImportMap(bad)), absl::StatusCode::kInvalidArgument);
  ASSERT_OK_AND_ASSIGN(v1::ListSessionsResponse after, registry->ListSessions(""));
  EXPECT_EQ(after.sessions_size(), before.sessions_size());
}

TEST_F(LaserMapsTest, GetMapCarriesTheMapsSelfCheckAndAClosedSessionKeepsItsVerdict) {
  std::string id;
  v1::MapSelfCheck listed;
  {
    auto registry = MakeRegistry();
    ASSERT_OK_AND_ASSIGN(v1::Session session, registry->CreateSession(TestSessionRequest("r1")));
    id = session.session_id();
    // Across the room and back four times: submaps far enough apart in time to be compared.
    for (int pass = 0; pass < 4; ++pass) DriveAcross(*registry, id, 100.0 * pass);

    // Open: GetMap checks the map as it stands; the session has no final verdict yet.
    ASSERT_OK_AND_ASSIGN(v1::SegmentMap live, registry->GetMap(id));
    ASSERT_TRUE(live.has_self_check());
    const v1::MapSelfCheck& check = live.self_check();
    EXPECT_TRUE(check.consistent()) << check.verdict();
    EXPECT_EQ(check.verdict().rfind("consistent: ", 0), 0u) << check.verdict();
    EXPECT_EQ(check.nodes(), live.graph_nodes());
    EXPECT_GE(check.submaps(), 3u);
    EXPECT_GT(check.evidence(), 0u);  // the passes' walls were compared, and agree
    EXPECT_EQ(check.areas_contradicting(), 0u);
    EXPECT_EQ(check.worst_areas_size(), 0);
    EXPECT_EQ(check.contradicting_cells_size(),
              2 * static_cast<int>(check.contradicting_cell_count()));
    EXPECT_DOUBLE_EQ(check.resolution(), 0.1);
    ASSERT_OK_AND_ASSIGN(v1::SegmentMap again, registry->GetMap(id));  // from the kept casts
    EXPECT_EQ(again.self_check().verdict(), check.verdict());
    ASSERT_OK_AND_ASSIGN(v1::Session open, registry->GetSession(id));
    EXPECT_FALSE(open.has_self_check());

    // Closed: the final map's verdict is stored with the session, without the cells.
    ASSERT_OK_AND_ASSIGN(v1::Session closed, registry->CloseSession(id));
    ASSERT_TRUE(closed.has_self_check());
    listed = closed.self_check();
    EXPECT_TRUE(listed.consistent());
    EXPECT_EQ(listed.contradicting_cells_size(), 0);
    ASSERT_OK_AND_ASSIGN(v1::SegmentMap final_map, registry->GetMap(id));
    EXPECT_EQ(final_map.self_check().verdict(), listed.verdict());
  }
  // ... and shown by ListSessions after a restart without loading the session.
  auto registry = MakeRegistry();
  ASSERT_OK_AND_ASSIGN(v1::ListSessionsResponse sessions, registry->ListSessions("r1"));
  ASSERT_EQ(sessions.sessions_size(), 1);
  EXPECT_FALSE(sessions.sessions(0).resident());
  EXPECT_EQ(sessions.sessions(0).self_check().SerializeAsString(), listed.SerializeAsString());

  // A session that keeps no scans has no self-check to give, and GetMap says nothing of one.
  v1::CreateSessionRequest request = TestSessionRequest("r2");
  request.mutable_laser()->mutable_params()->set_loop_closure(false);
  ASSERT_OK_AND_ASSIGN(v1::Session plain, registry->CreateSession(request));
  DriveAcross(*registry, plain.session_id());
  ASSERT_OK_AND_ASSIGN(v1::SegmentMap map, registry->GetMap(plain.session_id()));
  EXPECT_FALSE(map.has_self_check());
  ASSERT_OK_AND_ASSIGN(v1::Session closed, registry->CloseSession(plain.session_id()));
  EXPECT_FALSE(closed.has_self_check());
}

}  // namespace
}  // namespace waymark::service
