// Active exploration over the wire: the real waymark-server and the simulator in a closed go-stop
// loop (client/sessions/sim_explore.h). Suggestions respect the limits, the robot never touches a
// wall, and a short run maps most of a small world; bad exploration configs are refused.

#include <signal.h>

#include <cmath>
#include <vector>
#include <memory>
#include <string>

#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include "client/sim/sim_robot.h"
#include "client/sim/sim_world.h"
#include "client/lib/slam_client.h"
#include "client/sessions/sim_explore.h"
#include "tests/support/server_process.h"

namespace waymark {
namespace {

using testing::ServerProcess;

// Two rooms joined by a doorway, one with a free-standing wall: small enough for a short test,
// with a trap (the far room) and an obstacle to go round.
constexpr char kTwoRooms[] = R"(name two-rooms
start 1.5 2 0
wall 0 0 12 0
wall 0 5 12 5
wall 0 0 0 5
wall 12 0 12 5
wall 6 0 6 1.8
wall 6 3.2 6 5
wall 9 1.5 9 3.5
)";

class ExplorationServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::MakeTempDir("waymark-explore-test");
    auto server = ServerProcess::Start(testing::ServerBinary(), dir_ + "/w.db");
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = std::move(*server);
    client_ = std::make_unique<client::SlamClient>(
        grpc::CreateChannel(server_->address(), grpc::InsecureChannelCredentials()));
    auto world = adapters::ParseWorld(kTwoRooms);
    ASSERT_TRUE(world.ok()) << world.status();
    world_ = *world;
  }

  absl::StatusOr<cli::ExploreResult> Explore(v1::ExplorationConfig::Mode mode, double seconds,
                                             std::uint64_t seed) {
    cli::ExploreOptions options;
    options.mode = mode;
    options.duration_s = seconds;
    options.seed = seed;
    return cli::RunExploration(*client_, world_, options);
  }

  std::string dir_;
  std::unique_ptr<ServerProcess> server_;
  std::unique_ptr<client::SlamClient> client_;
  adapters::World world_;
};

void ExpectSafeSuggestions(const cli::ExploreResult& result) {
  ASSERT_FALSE(result.scans.empty());
  for (const cli::ScanRecord& scan : result.scans) {
    const v1::SuggestedControl& s = scan.suggestion;
    EXPECT_NE(s.behaviour(), v1::SuggestedControl::BEHAVIOUR_UNSPECIFIED);
    EXPECT_GE(s.linear(), 0.0);
    EXPECT_LE(s.linear(), 0.15 + 1e-9);
    EXPECT_LE(std::abs(s.angular()), 0.17 + 1e-9);
    EXPECT_DOUBLE_EQ(s.duration(), 4.0);
  }
  EXPECT_EQ(result.collisions, 0);
}

// The goal layer's end: the run stops when the session says DONE, the small world mapped.
TEST_F(ExplorationServerTest, ActiveRunMapsASmallWorldAndSaysDoneWithoutTouchingAWall) {
  for (std::uint64_t seed : {1u, 2u}) {
    auto result = Explore(v1::ExplorationConfig::ACTIVE, 1800, seed);
    ASSERT_TRUE(result.ok()) << result.status() << "\n" << server_->Log();
    ExpectSafeSuggestions(*result);
    const cli::ScanRecord& last = result->scans.back();
    EXPECT_TRUE(result->finished) << "seed " << seed;
    EXPECT_EQ(last.exploration.state(), v1::ExplorationProgress::DONE)
        << "seed " << seed << ": " << last.exploration.reason();
    EXPECT_EQ(last.suggestion.behaviour(), v1::SuggestedControl::FINISHED);
    EXPECT_LT(result->sim_time_s, 1800) << "seed " << seed;
    EXPECT_GE(last.completeness, 0.9) << "seed " << seed;
    EXPECT_LT(last.loc_error_m, 0.3) << "seed " << seed;
    // The paper's objective chose among the controls that follow the path.
    bool scored_on_the_way = false;
    for (const cli::ScanRecord& scan : result->scans) {
      scored_on_the_way = scored_on_the_way ||
                          (scan.suggestion.behaviour() == v1::SuggestedControl::TO_TARGET &&
                           scan.suggestion.j() != 0.0);
    }
    EXPECT_TRUE(scored_on_the_way) << "seed " << seed;
  }
}

TEST_F(ExplorationServerTest, FrontierRunSaysDoneWithoutTouchingAWall) {
  auto result = Explore(v1::ExplorationConfig::FRONTIER, 1800, 1);
  ASSERT_TRUE(result.ok()) << result.status() << "\n" << server_->Log();
  ExpectSafeSuggestions(*result);
  EXPECT_EQ(result->scans.back().exploration.state(), v1::ExplorationProgress::DONE)
      << result->scans.back().exploration.reason();
  EXPECT_GE(result->scans.back().completeness, 0.8);
}

// Floors on the built-in worlds of the README tour and docs/results.md's exploration table, on the
// map and pose the session answers (map frame, after the back end). The goal layer steers in the
// EKF's frame, so the robot drives the same path whatever the back end does: a drop here is the
// answered map drifting off the walls it saw. The two-rooms world above is too small for that
// (about 30 scans): issue 33's local matching chained its per-node match errors into 0.1-0.25 m
// over the corridor's 146 scans with no loop closure to take them back, and corridor seed 1 went
// from 97.9 % to 73.7 % of the walls on the same path (final error 0.016 -> 0.185 m).
absl::StatusOr<cli::ExploreResult> ExploreBuiltIn(client::SlamClient& client,
                                                 const std::string& name,
                                                 v1::ExplorationConfig::Mode mode,
                                                 std::uint64_t seed) {
  auto world = adapters::LoadWorld(name);
  if (!world.ok()) return world.status();
  cli::ExploreOptions options;
  options.mode = mode;
  options.duration_s = 1800;
  options.seed = seed;
  return cli::RunExploration(client, *world, options);
}

// The README's tour: `sim explore --world corridor --mode active --seed 1`. Measured: 0.980 of the
// walls, 0.014 m (local matching's learned prior, issue 33's fourth part); 0.979 and 0.016 m with
// the EKF's frame as the map's before issue 33; 0.737 and 0.185 m with the prior alone.
TEST_F(ExplorationServerTest, ReadmeCorridorRunMapsItsWallsAndEndsWhereItIs) {
  auto result = ExploreBuiltIn(*client_, "corridor", v1::ExplorationConfig::ACTIVE, 1);
  ASSERT_TRUE(result.ok()) << result.status() << "\n" << server_->Log();
  EXPECT_EQ(result->collisions, 0);
  EXPECT_TRUE(result->finished);
  const cli::ScanRecord& last = result->scans.back();
  EXPECT_EQ(last.exploration.state(), v1::ExplorationProgress::DONE) << last.exploration.reason();
  EXPECT_GE(last.completeness, 0.9);
  EXPECT_LT(last.loc_error_m, 0.1);
}

// `loop` (a ring corridor), active and frontier, seeds 1-5: means over the ten runs. Measured
// (docs/results.md): 0.929 of the walls and a final error of 0.107 m with local matching's learned
// prior; 0.757 and 0.142 m with the prior alone; 0.946 and 0.066 m before issue 33.
TEST_F(ExplorationServerTest, LoopWorldMapsStayOnTheWallsOverFiveSeeds) {
  double completeness = 0.0, final_error = 0.0;
  int runs = 0;
  for (v1::ExplorationConfig::Mode mode :
       {v1::ExplorationConfig::ACTIVE, v1::ExplorationConfig::FRONTIER}) {
    for (std::uint64_t seed = 1; seed <= 5; ++seed) {
      auto result = ExploreBuiltIn(*client_, "loop", mode, seed);
      ASSERT_TRUE(result.ok()) << result.status() << "\n" << server_->Log();
      EXPECT_EQ(result->collisions, 0) << "mode " << mode << " seed " << seed;
      completeness += result->scans.back().completeness;
      final_error += result->scans.back().loc_error_m;
      ++runs;
    }
  }
  EXPECT_GE(completeness / runs, 0.88);
  EXPECT_LT(final_error / runs, 0.15);
}

// goal_layer = false: the paper's planner exactly as published; no goal layer, no end.
TEST_F(ExplorationServerTest, PaperModeKeepsTheOneStepPlannerAndRunsToTheEnd) {
  cli::ExploreOptions options;
  options.mode = v1::ExplorationConfig::ACTIVE;
  options.goal_layer = false;
  options.duration_s = 200;
  auto result = cli::RunExploration(*client_, world_, options);
  ASSERT_TRUE(result.ok()) << result.status();
  ExpectSafeSuggestions(*result);
  EXPECT_FALSE(result->finished);
  EXPECT_NEAR(result->sim_time_s, 200, 1e-6);
  bool optimal = false;
  for (const cli::ScanRecord& scan : result->scans) {
    optimal = optimal || scan.suggestion.behaviour() == v1::SuggestedControl::OPTIMAL;
    EXPECT_NE(scan.suggestion.behaviour(), v1::SuggestedControl::TO_TARGET);
    EXPECT_FALSE(scan.exploration.has_target());
    EXPECT_EQ(scan.exploration.state(), v1::ExplorationProgress::STATE_UNSPECIFIED);
  }
  EXPECT_TRUE(optimal);
}

TEST_F(ExplorationServerTest, WanderRunDrivesAndTurnsWithoutTouchingAWall) {
  auto result = Explore(v1::ExplorationConfig::WANDER, 300, 1);
  ASSERT_TRUE(result.ok()) << result.status();
  ExpectSafeSuggestions(*result);
  for (const cli::ScanRecord& scan : result->scans) {
    EXPECT_EQ(scan.suggestion.behaviour(), v1::SuggestedControl::WANDER);
  }
  EXPECT_GT(result->distance_m, 10.0);
}

// A session request for robot-1 with a 181-beam, 1-degree laser and ACTIVE exploration.
v1::CreateSessionRequest ActiveRequest() {
  v1::CreateSessionRequest request;
  request.set_robot_id("robot-1");
  v1::LaserGeometry* g = request.mutable_laser()->mutable_laser();
  g->set_angle_min(-M_PI / 2);
  g->set_angle_increment(M_PI / 180);
  g->set_beam_count(181);
  request.mutable_laser()->mutable_exploration()->set_mode(v1::ExplorationConfig::ACTIVE);
  return request;
}

TEST_F(ExplorationServerTest, ActiveSessionReportsItsEffectiveExplorationConfig) {
  v1::CreateSessionRequest request = ActiveRequest();
  request.mutable_laser()->mutable_exploration()->set_max_linear(0.3);
  auto session = client_->CreateSession(request);
  ASSERT_TRUE(session.ok()) << session.status();
  const v1::ExplorationConfig& e = session->laser().exploration();
  EXPECT_EQ(e.mode(), v1::ExplorationConfig::ACTIVE);
  EXPECT_DOUBLE_EQ(e.max_linear(), 0.3);
  EXPECT_DOUBLE_EQ(e.max_angular(), 0.17);
  EXPECT_DOUBLE_EQ(e.observation_period(), 4.0);
  EXPECT_DOUBLE_EQ(e.control_period(), 0.1);
  EXPECT_EQ(e.angular_steps(), 7u);
}

// Streams one odometry reading and one scan of `world` from its start pose at `stamp` into
// `session_id`; returns the scan's answer.
v1::SlamUpdate ScanOnce(client::SlamClient& client, const std::string& session_id,
                        const adapters::World& world, double stamp) {
  adapters::Simulation sim(world, adapters::SimOptions{});
  std::vector<v1::SlamUpdate> updates;
  auto stream = client.StreamSensorData(session_id, 1, [&](const v1::SlamUpdate& u) {
    updates.push_back(u);
  });
  v1::Odometry odometry;
  odometry.set_stamp(stamp);
  odometry.mutable_pose()->set_x(world.start.x);
  odometry.mutable_pose()->set_y(world.start.y);
  odometry.mutable_pose()->set_theta(world.start.theta);
  EXPECT_TRUE(stream->SendOdometry(odometry).ok());
  v1::LaserScan scan;
  scan.set_stamp(stamp);
  const adapters::LaserReading reading = sim.Scan();
  for (float r : reading.ranges) scan.add_ranges(r);
  EXPECT_TRUE(stream->SendScan(scan).ok());
  EXPECT_TRUE(stream->Finish().ok());
  EXPECT_EQ(updates.size(), 1u);
  return updates.empty() ? v1::SlamUpdate() : updates.front();
}

TEST_F(ExplorationServerTest, ActiveSessionStillSuggestsAfterAServerRestart) {
  auto session = client_->CreateSession(ActiveRequest());
  ASSERT_TRUE(session.ok()) << session.status();
  const v1::SlamUpdate before = ScanOnce(*client_, session->session_id(), world_, 1.0);
  // The goal layer leads (to the unseen space behind the robot, first).
  EXPECT_EQ(before.suggestion().behaviour(), v1::SuggestedControl::TO_TARGET);
  EXPECT_EQ(before.exploration().state(), v1::ExplorationProgress::EXPLORING);
  ASSERT_EQ(server_->Stop(SIGTERM), 0);
  auto restarted = ServerProcess::Start(testing::ServerBinary(), dir_ + "/w.db");
  ASSERT_TRUE(restarted.ok()) << restarted.status();
  server_ = std::move(*restarted);
  client_ = std::make_unique<client::SlamClient>(
      grpc::CreateChannel(server_->address(), grpc::InsecureChannelCredentials()));
  // The resumed session is still active (its exploration config was stored with it).
  const v1::SlamUpdate after = ScanOnce(*client_, session->session_id(), world_, 2.0);
  EXPECT_FALSE(after.has_rejection()) << after.rejection().message();
  EXPECT_EQ(after.suggestion().behaviour(), v1::SuggestedControl::TO_TARGET);
  EXPECT_EQ(after.exploration().state(), v1::ExplorationProgress::EXPLORING);
  EXPECT_DOUBLE_EQ(after.suggestion().duration(), 4.0);
}

TEST_F(ExplorationServerTest, BadExplorationConfigsAreRefusedNamingTheField) {
  const auto refused = [&](const std::function<void(v1::ExplorationConfig*)>& edit,
                           const std::string& field) {
    v1::CreateSessionRequest request = ActiveRequest();
    edit(request.mutable_laser()->mutable_exploration());
    auto session = client_->CreateSession(request);
    ASSERT_FALSE(session.ok()) << field;
    EXPECT_EQ(session.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_NE(session.status().message().find(field), std::string::npos)
        << session.status().message();
  };
  refused([](v1::ExplorationConfig* e) { e->set_max_linear(-1); }, "laser.exploration.max_linear");
  refused([](v1::ExplorationConfig* e) { e->set_max_angular(NAN); }, "laser.exploration.max_angular");
  refused([](v1::ExplorationConfig* e) { e->set_angular_steps(4); }, "laser.exploration.angular_steps");
  refused([](v1::ExplorationConfig* e) { e->set_mode(static_cast<v1::ExplorationConfig::Mode>(7)); },
          "laser.exploration.mode");
  refused([](v1::ExplorationConfig* e) { e->set_control_period(9); }, "control_period");
}

}  // namespace
}  // namespace waymark
