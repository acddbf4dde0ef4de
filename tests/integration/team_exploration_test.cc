// Several robots exploring one map over the wire (issue 38; client/sessions/sim_team_explore.h):
// the real waymark-server, two simulated robots in the built-in office world, each its own active
// session in one shared map. Together they reach DONE with at least the map one robot makes alone,
// each in fewer decisions than the robot alone, and neither touches a wall or the other.

#include <algorithm>
#include <memory>
#include <string>

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include "client/lib/slam_client.h"
#include "client/sessions/sim_explore.h"
#include "client/sessions/sim_team_explore.h"
#include "client/sim/sim_world.h"
#include "tests/support/server_process.h"

namespace waymark {
namespace {

using testing::ServerProcess;

TEST(TeamExplorationServerTest, TwoRobotsInOneMapAreDoneWithAsMuchMappedInFewerDecisionsEach) {
  const std::string dir = testing::MakeTempDir("waymark-team-explore-test");
  auto server = ServerProcess::Start(testing::ServerBinary(), dir + "/w.db");
  ASSERT_TRUE(server.ok()) << server.status();
  client::SlamClient client(
      grpc::CreateChannel((*server)->address(), grpc::InsecureChannelCredentials()));
  auto world = adapters::LoadWorld("office");
  ASSERT_TRUE(world.ok()) << world.status();

  cli::ExploreOptions run;
  run.mode = v1::ExplorationConfig::ACTIVE;
  run.duration_s = 1800;
  run.seed = 1;
  auto alone = cli::RunExploration(client, *world, run);
  ASSERT_TRUE(alone.ok()) << alone.status() << "\n" << (*server)->Log();
  ASSERT_TRUE(alone->finished);

  cli::TeamExploreOptions team;
  team.run = run;
  team.robots = 2;
  team.map = "office-team";
  auto together = cli::RunTeamExploration(client, *world, team);
  ASSERT_TRUE(together.ok()) << together.status() << "\n" << (*server)->Log();
  ASSERT_EQ(together->robots.size(), 2u);
  EXPECT_TRUE(together->finished);
  const double alone_completeness = alone->scans.back().completeness;
  EXPECT_GE(together->completeness, alone_completeness - 0.02)
      << "alone " << alone_completeness;
  for (size_t k = 0; k < together->robots.size(); ++k) {
    const cli::TeamRobot& robot = together->robots[k];
    SCOPED_TRACE("robot " + std::to_string(k + 1));
    EXPECT_EQ(robot.run.scans.back().exploration.state(), v1::ExplorationProgress::DONE)
        << robot.run.scans.back().exploration.reason();
    EXPECT_EQ(robot.run.collisions, 0);
    EXPECT_EQ(robot.tied_in_time_s, 0.0) << "a known start ties it in at its first scan";
    EXPECT_LT(robot.run.scans.size(), alone->scans.size());
    // Its map-frame estimate stays on the truth.
    EXPECT_LT(robot.run.scans.back().loc_error_m, 0.3);
  }
  // Both sessions are trajectories of the map, tied in.
  auto map = client.GetMapInfo("office-team");
  ASSERT_TRUE(map.ok()) << map.status();
  ASSERT_EQ(map->trajectories_size(), 2);
  for (const v1::MapTrajectory& t : map->trajectories()) EXPECT_TRUE(t.tied_in());
  // A map that already holds trajectories is refused: its frame is not the next run's start.
  auto again = cli::RunTeamExploration(client, *world, team);
  EXPECT_EQ(again.status().code(), absl::StatusCode::kFailedPrecondition);
}

}  // namespace
}  // namespace waymark
