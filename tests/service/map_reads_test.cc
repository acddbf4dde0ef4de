// The map registry's reads of a shared map (issue 38, map_reads.cc) on a real SQLite file, the
// sessions' nodes faked: the map's pose graph is solved once and its solution reused while
// nothing it is solved from changes, solved again when a node moves, and let go with the map. And
// a robot found among look-alike places stays marked so after its tie, its follow and a restart.

#include <memory>
#include <string>
#include <vector>

#include "gtest/gtest.h"
#include "server/service/slam/map_registry.h"
#include "storage/map_store.h"
#include "storage/slam_store.h"
#include "tests/storage/status_testing.h"
#include "tests/storage/temp_dir.h"

namespace waymark::service {
namespace {

namespace ls = waymark::laser_slam;
using ::waymark::storage::testing::TempDir;

// `count` nodes every 0.5 m along x in the robot's own frame, two scans apart.
std::vector<ls::NodeView> Straight(int count) {
  std::vector<ls::NodeView> nodes;
  for (int i = 0; i < count; ++i) {
    ls::NodeView node;
    node.scan = static_cast<std::uint64_t>(2 * i + 1);
    node.stamp = static_cast<double>(i);
    node.global = ls::Pose2{0.5 * i, 0.0, 0.0};
    node.step_sigma = Eigen::Vector3d(0.02, 0.02, 0.005);
    nodes.push_back(node);
  }
  return nodes;
}

// Every node's origin and map pose, as the answer gives them.
std::vector<double> NodeOrigins(const v1::Map& map) {
  std::vector<double> out;
  for (const v1::MapTrajectory& t : map.trajectories()) {
    for (const v1::MapOriginSample& s : t.node_origins()) {
      out.insert(out.end(), {s.origin().x(), s.origin().y(), s.origin().theta(),
                             s.map_pose().x(), s.map_pose().y(), s.map_pose().theta()});
    }
  }
  return out;
}

// A SQLite file in `dir` with one session per id (robot "robot-<id>") and its map store.
struct Stores {
  std::unique_ptr<storage::SlamStore> sessions;
  std::unique_ptr<storage::MapStore> maps;
};
absl::StatusOr<Stores> StoresWithSessions(const TempDir& dir, const std::vector<std::string>& ids) {
  const std::string db = dir.File("w.db");
  Stores out;
  absl::StatusOr<std::unique_ptr<storage::SlamStore>> sessions = storage::OpenSqliteSlamStore(db);
  if (!sessions.ok()) return sessions.status();
  out.sessions = *std::move(sessions);
  absl::StatusOr<std::unique_ptr<storage::MapStore>> maps = storage::OpenSqliteMapStore(db);
  if (!maps.ok()) return maps.status();
  out.maps = *std::move(maps);
  for (const std::string& id : ids) {
    storage::SlamSessionRecord session;
    session.id = id;
    session.robot_id = "robot-" + id;
    if (absl::StatusOr<storage::SlamSessionRecord> created = out.sessions->CreateSession(session);
        !created.ok()) {
      return created.status();
    }
  }
  return out;
}

TEST(MapReadsTest, TheGraphIsSolvedOncePerChangeAndLetGoWithTheMap) {
  TempDir dir;
  ASSERT_OK_AND_ASSIGN(Stores stores, StoresWithSessions(dir, {"a", "b"}));
  MapRegistry registry(stores.maps.get(), nullptr);
  ASSERT_OK(registry.CreateMap("floor"));
  ASSERT_OK(registry.Join("floor", "a"));  // the map frame's
  ASSERT_OK(registry.Join("floor", "b"));
  ASSERT_OK(registry.Tie("floor", "b", storage::MapTie{0.0, 1.0, 0.0}));

  std::vector<ls::NodeView> a = Straight(20), b = Straight(12);
  int reads = 0;
  const MapRegistry::SessionNodes nodes =
      [&](const std::string& id) -> absl::StatusOr<TrajectoryNodes> {
    ++reads;
    return TrajectoryNodes{id == "a" ? a : b, /*resident=*/false, {}};
  };
  EXPECT_FALSE(registry.GraphStats("floor").has_value());
  ASSERT_OK_AND_ASSIGN(v1::Map first, registry.GetMapWithNodeOrigins("floor", nodes));
  ASSERT_OK_AND_ASSIGN(v1::Map second, registry.GetMapWithNodeOrigins("floor", nodes));
  EXPECT_EQ(reads, 4);  // the sessions are read every time: only the solve is kept
  ASSERT_TRUE(registry.GraphStats("floor").has_value());
  EXPECT_EQ(registry.GraphStats("floor")->solved, 1u);
  EXPECT_EQ(registry.GraphStats("floor")->reused, 1u);
  EXPECT_EQ(NodeOrigins(first).size(), 6u * (20 + 12));
  EXPECT_EQ(NodeOrigins(first), NodeOrigins(second));

  // Robot b's session moved a node (its own closure, say): solved again, the node placed anew.
  b[5].global.y += 0.2;
  ASSERT_OK_AND_ASSIGN(v1::Map moved, registry.GetMapWithNodeOrigins("floor", nodes));
  EXPECT_EQ(registry.GraphStats("floor")->solved, 2u);
  EXPECT_NE(NodeOrigins(moved), NodeOrigins(first));
  ASSERT_OK(registry.GetMapWithNodeOrigins("floor", nodes));
  EXPECT_EQ(registry.GraphStats("floor")->solved, 2u);
  EXPECT_EQ(registry.GraphStats("floor")->reused, 2u);

  ASSERT_OK(registry.DeleteMap("floor", /*force=*/true));
  EXPECT_FALSE(registry.GraphStats("floor").has_value());
}

TEST(MapReadsTest, ATieFoundAmongLookAlikePlacesIsMarkedAfterItsFollowAndARestart) {
  TempDir dir;
  ASSERT_OK_AND_ASSIGN(Stores stores, StoresWithSessions(dir, {"a", "b", "c"}));
  const auto warning_of = [](const v1::Map& map, const std::string& id) {
    for (const v1::MapTrajectory& t : map.trajectories()) {
      if (t.session_id() == id) return t.warning();
    }
    return std::string("(no trajectory)");
  };
  const std::string twins = "tied in after 29 of its 164 searches found look-alike places";
  {
    MapRegistry registry(stores.maps.get(), nullptr);
    ASSERT_OK(registry.CreateMap("floor"));
    for (const std::string id : {"a", "b", "c"}) ASSERT_OK(registry.Join("floor", id));
    // b's searches found look-alikes before its tie; c's did not.
    ls::TieProgress among_twins;
    among_twins.searches = 164;
    among_twins.matches = 78;
    among_twins.ambiguous = 29;
    registry.Searched("b", among_twins);
    ls::TieProgress clear;
    clear.searches = 6;
    clear.matches = 6;
    registry.Searched("c", clear);
    ASSERT_OK_AND_ASSIGN(v1::Map searching, registry.GetMap("floor"));
    EXPECT_NE(warning_of(searching, "b").find("29 of 164 searches found look-alike places"),
              std::string::npos);
    ASSERT_OK(registry.Tie("floor", "b", storage::MapTie{18.3, 16.1, 3.1}));
    ASSERT_OK(registry.Tie("floor", "c", storage::MapTie{0.0, 1.0, 0.0}));
    ASSERT_OK_AND_ASSIGN(v1::Map tied, registry.GetMap("floor"));
    EXPECT_EQ(warning_of(tied, "b").find(twins), 0u) << warning_of(tied, "b");
    EXPECT_EQ(warning_of(tied, "c"), "");
    // Its follow-up matches hold (a half-turned robot's do, in a floor with point symmetry): the
    // mark stays, and is stored with the samples.
    ls::FollowProgress holding;
    holding.attempts = 20;
    holding.matched = 15;
    ASSERT_OK(registry.Follow("floor", "b",
                              {ls::OriginSample{1, 0.0, ls::Pose2{18.3, 16.1, 3.1}},
                               ls::OriginSample{9, 4.0, ls::Pose2{18.4, 16.1, 3.1}}},
                              holding));
    ASSERT_OK_AND_ASSIGN(v1::Map followed, registry.GetMap("floor"));
    EXPECT_EQ(warning_of(followed, "b").find(twins), 0u) << warning_of(followed, "b");
  }
  MapRegistry restarted(stores.maps.get(), nullptr);
  ASSERT_OK(restarted.Load());
  ASSERT_OK_AND_ASSIGN(v1::Map loaded, restarted.GetMap("floor"));
  EXPECT_EQ(warning_of(loaded, "b").find(twins), 0u) << warning_of(loaded, "b");
  EXPECT_EQ(warning_of(loaded, "c"), "");
}

}  // namespace
}  // namespace waymark::service
