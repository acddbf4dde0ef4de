// The exploration loop (sim_explore.h) and `waymark sim ...` against the fake SlamService
// answering every scan with a fixed suggestion: the go-stop protocol's messages and stamps, the
// scan count for a duration, the outputs, and the errors.
#include "client/sessions/sim_explore.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "client/datasets/carmen_log.h"
#include "client/lib/channel.h"
#include "client/cli/cli.h"
#include "tests/client/fake_slam_service.h"
#include "tests/client/test_util.h"

namespace waymark::cli {
namespace {

using ::testing::HasSubstr;
using waymark::testing::CliResult;
using waymark::testing::FakeSlamServer;
using waymark::testing::ReadAll;
using waymark::testing::RunWaymark;
using waymark::testing::ScopedTempDir;

// A 10 x 6 m room; the robot starts in the middle facing +x, 4.75 m from the far wall.
constexpr char kRoom[] =
    "name room\n"
    "start 5 3 0\n"
    "box 0 0 10 6\n";

v1::SuggestedControl Straight(double duration = 4) {
  v1::SuggestedControl c;
  c.set_linear(0.1);
  c.set_angular(0);
  c.set_duration(duration);
  c.set_behaviour(v1::SuggestedControl::WANDER);
  c.set_planning_ms(1.5);
  return c;
}

class SimExploreTest : public ::testing::Test {
 protected:
  absl::StatusOr<ExploreResult> Explore(
      double duration, v1::ExplorationConfig::Mode mode = v1::ExplorationConfig::WANDER,
      const v1::ExplorationConfig& exploration = {}, const std::string& record_dir = "") {
    auto world = adapters::ParseWorld(kRoom);
    EXPECT_TRUE(world.ok()) << world.status();
    client::SlamClient client(client::MakeChannel(server_.address()));
    ExploreOptions options;
    options.mode = mode;
    options.duration_s = duration;
    options.seed = 7;
    options.answer_timeout = absl::Seconds(10);
    options.exploration = exploration;
    options.record_dir = record_dir;
    return RunExploration(client, *world, options);
  }

  CliResult Run(std::vector<std::string> args) {
    return RunWaymark(server_.address(), std::move(args));
  }

  std::string WorldFile() {
    const auto path = dir_.path() / "room.world";
    std::ofstream(path) << kRoom;
    return path.string();
  }

  ScopedTempDir dir_;
  FakeSlamServer server_;
};

void ExpectStrictlyIncreasing(const std::vector<double>& stamps, const char* what) {
  for (size_t i = 1; i < stamps.size(); ++i) {
    EXPECT_GT(stamps[i], stamps[i - 1]) << what << " " << i;
  }
}

TEST_F(SimExploreTest, GoStopLoopSendsOdometryEveryControlStepAndAScanPerHold) {
  server_.service().set_suggestion(Straight());
  auto result = Explore(20);
  ASSERT_TRUE(result.ok()) << result.status();

  // Scans at 0, 4, 8, 12, 16, 20; odometry at 0 and every 0.1 s after.
  const std::vector<double> scans = server_.service().scan_stamps();
  const std::vector<double> odometry = server_.service().odometry_stamps();
  ASSERT_EQ(scans.size(), 6u);
  ASSERT_EQ(odometry.size(), 201u);
  for (size_t i = 0; i < scans.size(); ++i) EXPECT_NEAR(scans[i], 4.0 * i, 1e-6);
  for (size_t i = 0; i < odometry.size(); ++i) EXPECT_NEAR(odometry[i], 0.1 * i, 1e-6);
  ExpectStrictlyIncreasing(scans, "scan");
  ExpectStrictlyIncreasing(odometry, "odometry");
  EXPECT_EQ(server_.service().rejected(), 0);
  EXPECT_EQ(server_.service().max_outstanding_scans(), 1);  // go-stop: one scan at a time

  // The session: robot "sim", the simulator's LMS200 layout, the mode, server-default range.
  const v1::CreateSessionRequest create = server_.service().last_create();
  EXPECT_EQ(create.robot_id(), "sim");
  EXPECT_EQ(create.laser().laser().beam_count(), 181u);
  EXPECT_NEAR(create.laser().laser().angle_min(), -M_PI / 2, 1e-9);
  EXPECT_NEAR(create.laser().laser().angle_increment(), M_PI / 180, 1e-9);
  EXPECT_GT(create.laser().laser().no_return_range(), 8.0);
  EXPECT_NEAR(create.laser().laser_pose().x(), 0.16, 1e-12);
  EXPECT_EQ(create.laser().exploration().mode(), v1::ExplorationConfig::WANDER);
  EXPECT_FALSE(create.laser().params().has_max_range());

  // The robot drove 0.1 m/s for 20 s along +x; the records follow it.
  ASSERT_EQ(result->scans.size(), 6u);
  EXPECT_NEAR(result->sim_time_s, 20, 1e-6);
  EXPECT_NEAR(result->distance_m, 2.0, 0.05);
  EXPECT_NEAR(result->scans.back().true_pose.x, 7.0, 0.05);
  EXPECT_EQ(result->collisions, 0);
  EXPECT_EQ(result->early_stops, 0);
  EXPECT_EQ(result->scans.front().odometry_error_m, 0);  // odometry anchored at the first scan
  EXPECT_NEAR(result->scans.back().cov_trace_mean, 0.006, 1e-12);
  EXPECT_EQ(result->scans.back().suggestion.behaviour(), v1::SuggestedControl::WANDER);
  for (const ScanRecord& r : result->scans) {
    EXPECT_GE(r.completeness, 0);
    EXPECT_LE(r.completeness, 1);
  }
  // Every wall of the empty room is visible: both completeness figures measure the same walls
  // (sampled every 2 and every 5 cm).
  EXPECT_NEAR(result->visible_wall_share, 1.0, 1e-9);
  EXPECT_GT(result->completeness_visible, 0);
  EXPECT_NEAR(result->completeness_visible, result->scans.back().completeness, 0.02);

  const nlohmann::json summary = ExploreSummary(*result);
  EXPECT_EQ(summary["scans"], 6);
  EXPECT_EQ(summary["mode"], "wander");
  EXPECT_EQ(summary["world"], "room");
  EXPECT_EQ(summary["wall_following_share"], 0.0);
  EXPECT_NEAR(summary["planning_ms_p50"].get<double>(), 1.5, 1e-12);
  EXPECT_NEAR(summary["cov_trace_mean"].get<double>(), 0.0035, 1e-12);
  EXPECT_EQ(summary["completeness_visible"], result->completeness_visible);
  EXPECT_EQ(summary["visible_wall_share"], result->visible_wall_share);
}

// --record: what the robot sent, as a CARMEN log that `waymark slam replay` reads back: every
// odometry message and every scan, at their stamps, the laser's pose the odometry's moved by
// the simulator's mount (0.16 m ahead), the ranges as sent.
TEST_F(SimExploreTest, ARecordingHoldsWhatWasSentAsACarmenLog) {
  server_.service().set_suggestion(Straight());
  const std::string record = (dir_.path() / "recorded").string();
  auto result = Explore(20, v1::ExplorationConfig::WANDER, {}, record);
  ASSERT_TRUE(result.ok()) << result.status();
  auto reader = adapters::CarmenLogReader::Open(record + "/robot1.clf",
                                                adapters::CarmenLogReader::Options{false});
  ASSERT_TRUE(reader.ok()) << reader.status();
  std::vector<double> scans, odometry;
  adapters::CarmenRecord line;
  while (true) {
    absl::StatusOr<bool> more = (*reader)->Next(&line);
    ASSERT_TRUE(more.ok()) << more.status();
    if (!*more) break;
    if (line.type == adapters::CarmenRecord::Type::kOdometry) {
      odometry.push_back(line.odometry.stamp);
      continue;
    }
    scans.push_back(line.laser.stamp);
    EXPECT_EQ(line.laser.ranges.size(), 181u);
    const adapters::CarmenPose& odom = line.laser.odom_pose;
    EXPECT_NEAR(line.laser.laser_pose.x, odom.x + 0.16 * std::cos(odom.theta), 1e-5);
    EXPECT_NEAR(line.laser.laser_pose.y, odom.y + 0.16 * std::sin(odom.theta), 1e-5);
    EXPECT_NEAR(line.laser.laser_pose.theta, odom.theta, 1e-6);
  }
  ASSERT_EQ(scans.size(), server_.service().scan_stamps().size());
  for (size_t i = 0; i < scans.size(); ++i) {
    EXPECT_NEAR(scans[i], server_.service().scan_stamps()[i], 1e-6);
  }
  ASSERT_EQ(odometry.size(), server_.service().odometry_stamps().size());
  for (size_t i = 0; i < odometry.size(); ++i) {
    EXPECT_NEAR(odometry[i], server_.service().odometry_stamps()[i], 1e-6);
  }
  // Nothing recorded without --record.
  EXPECT_FALSE(std::filesystem::exists(dir_.path() / "robot1.clf"));
}

// The simulated base takes the planner's velocity limits: the paper's 0.15 m/s unless the
// exploration config sets others (a faster plan on a base that clamps it would miss its arcs).
TEST_F(SimExploreTest, TheBaseDrivesAsFastAsTheExplorationConfigAllows) {
  v1::SuggestedControl fast = Straight();
  fast.set_linear(0.3);
  server_.service().set_suggestion(fast);
  auto paper = Explore(8);
  ASSERT_TRUE(paper.ok()) << paper.status();
  EXPECT_NEAR(paper->distance_m, 0.15 * 8, 0.05);

  v1::ExplorationConfig config;
  config.set_max_linear(0.3);
  config.set_max_angular(0.4);
  auto faster = Explore(8, v1::ExplorationConfig::WANDER, config);
  ASSERT_TRUE(faster.ok()) << faster.status();
  EXPECT_NEAR(faster->distance_m, 0.3 * 8, 0.05);
  EXPECT_NEAR(server_.service().last_create().laser().exploration().max_linear(), 0.3, 1e-12);
}

TEST_F(SimExploreTest, TheLastHoldIsCutAtTheDuration) {
  server_.service().set_suggestion(Straight());
  auto result = Explore(10);
  ASSERT_TRUE(result.ok()) << result.status();
  const std::vector<double> scans = server_.service().scan_stamps();
  ASSERT_EQ(scans.size(), 4u);  // 0, 4, 8, 10
  EXPECT_NEAR(scans.back(), 10, 1e-6);
  EXPECT_EQ(server_.service().odometry_received(), 101);
}

TEST_F(SimExploreTest, BlockedSuggestionsStandStillWhileTimePasses) {
  v1::SuggestedControl blocked;
  blocked.set_duration(4);
  blocked.set_behaviour(v1::SuggestedControl::BLOCKED);
  server_.service().set_suggestion(blocked);
  auto result = Explore(8);
  ASSERT_TRUE(result.ok()) << result.status();
  ASSERT_EQ(result->scans.size(), 3u);
  EXPECT_NEAR(result->distance_m, 0, 1e-12);
  EXPECT_NEAR(result->scans.back().time, 8, 1e-6);
  ExpectStrictlyIncreasing(server_.service().scan_stamps(), "scan");
}

TEST_F(SimExploreTest, NoSuggestionIsFailedPrecondition) {
  auto result = Explore(20, v1::ExplorationConfig::ACTIVE);
  ASSERT_FALSE(result.ok());
  EXPECT_EQ(result.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(std::string(result.status().message()),
              HasSubstr("session is not in active or wander mode"));
  EXPECT_EQ(server_.service().scans_received(), 1);
}

TEST_F(SimExploreTest, CliWritesEveryOutputAndOneJsonObject) {
  server_.service().set_suggestion(Straight());
  const auto out = dir_.path() / "run";
  CliResult r = Run({"--json", "sim", "explore", "--world", WorldFile(), "--mode", "wander",
                     "--duration", "12", "--seed", "3", "--out", out.string()});
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json json = nlohmann::json::parse(r.out);  // exactly one document
  ASSERT_TRUE(json.is_object());
  for (const char* key :
       {"completeness", "loc_error_mean_m", "loc_error_final_m", "cov_trace_mean", "collisions",
        "sim_time_s", "world", "mode", "seed", "distance_m", "scans", "segments",
        "wall_following_share", "odometry_error_final_m", "planning_ms_p50", "out_dir",
        "completeness_visible", "visible_wall_share"}) {
    EXPECT_TRUE(json.contains(key)) << key;
  }
  EXPECT_EQ(json["scans"], 4);
  EXPECT_EQ(json["seed"], 3);
  EXPECT_EQ(json["world"], "room");
  EXPECT_EQ(json["out_dir"], out.string());
  EXPECT_NEAR(json["sim_time_s"].get<double>(), 12, 1e-6);

  for (const char* file :
       {"trajectory_true.txt", "trajectory_estimated.txt", "trajectory_odometry.txt", "map.svg",
        "map.png", "timeline.csv", "timeline.svg", "timeline.png", "summary.json"}) {
    EXPECT_TRUE(std::filesystem::exists(out / file)) << file;
  }
  EXPECT_EQ(nlohmann::json::parse(ReadAll(out / "summary.json")), json);
  std::istringstream csv(ReadAll(out / "timeline.csv"));
  std::string header, line;
  std::getline(csv, header);
  EXPECT_THAT(header, HasSubstr("t_s,true_x"));
  int rows = 0;
  while (std::getline(csv, line)) rows += !line.empty();
  EXPECT_EQ(rows, 4);
  const std::string map_svg = ReadAll(out / "map.svg");
  EXPECT_THAT(map_svg, HasSubstr("true walls"));
  EXPECT_THAT(map_svg, HasSubstr("estimated trajectory"));
  EXPECT_THAT(ReadAll(out / "timeline.svg"), HasSubstr("localisation error (m)"));
  EXPECT_FALSE(cv::imread((out / "timeline.png").string()).empty());
  EXPECT_FALSE(cv::imread((out / "map.png").string()).empty());
}

TEST_F(SimExploreTest, CliLaserModeAndOdometryErrorReachTheSimulator) {
  server_.service().set_suggestion(Straight());
  const auto run = [&](std::vector<std::string> extra) {
    std::vector<std::string> args = {"--json", "sim", "explore", "--world", WorldFile(),
                                     "--duration", "12", "--out", (dir_.path() / "flags").string()};
    args.insert(args.end(), extra.begin(), extra.end());
    CliResult r = Run(args);
    EXPECT_EQ(r.code, 0) << r.err;
    return r.code == 0 ? nlohmann::json::parse(r.out) : nlohmann::json::object();
  };
  // Perfect odometry stays on the truth; the default drifts.
  EXPECT_EQ(run({"--odometry-error", "0"})["odometry_error_final_m"], 0.0);
  EXPECT_GT(run({})["odometry_error_final_m"].get<double>(), 0.0);
  // The 0.5-degree mode sends 361 beams and says so when it creates the session.
  run({"--half-degree"});
  EXPECT_EQ(server_.service().last_create().laser().laser().beam_count(), 361u);
  EXPECT_NE(Run({"sim", "explore", "--world", WorldFile(), "--duration", "4",
                 "--odometry-error", "-1"}).code,
            0);
}

TEST_F(SimExploreTest, CliHumanOutputIsASummaryTable) {
  server_.service().set_suggestion(Straight());
  CliResult r = Run({"sim", "explore", "--world", WorldFile(), "--duration", "4", "--out",
                     (dir_.path() / "human").string()});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("completeness"));
  EXPECT_THAT(r.out, HasSubstr("completeness of the visible walls"));
  EXPECT_THAT(r.out, HasSubstr("visible wall share"));
  EXPECT_THAT(r.out, HasSubstr("collisions"));
  EXPECT_TRUE(r.err.empty()) << r.err;  // no progress bar when stderr is not a terminal
}

TEST_F(SimExploreTest, CliErrors) {
  CliResult unknown = Run({"sim", "explore", "--world", "atlantis", "--duration", "4"});
  EXPECT_EQ(unknown.code, 1);
  EXPECT_THAT(unknown.err, HasSubstr("corridor"));  // the built-in names are listed

  CliResult passive = Run({"sim", "explore", "--world", WorldFile(), "--duration", "4", "--out",
                           (dir_.path() / "passive").string()});
  EXPECT_EQ(passive.code, 1);
  EXPECT_THAT(passive.err, HasSubstr("FAILED_PRECONDITION"));

  std::ostringstream out, err;
  const char* argv[] = {"waymark", "--server", "127.0.0.1:1", "--timeout",  "2", "sim",
                        "explore", "--world",  "corridor",    "--duration", "4"};
  EXPECT_EQ(RunCli(11, argv, out, err, false), 1);
  EXPECT_THAT(err.str(), HasSubstr("UNAVAILABLE"));
}

TEST_F(SimExploreTest, WorldsListsTheBuiltInsWithTheirWallLength) {
  CliResult r = Run({"--json", "sim", "worlds"});
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json json = nlohmann::json::parse(r.out);
  std::vector<std::string> names;
  for (const auto& w : json["worlds"]) {
    names.push_back(w["name"]);
    EXPECT_GT(w["wall_length_m"].get<double>(), 10);
    // Some wall length is hidden (office: about 7.5 m of 87 m behind cabinets), never most of it.
    EXPECT_LE(w["visible_wall_m"].get<double>(), w["wall_length_m"].get<double>());
    EXPECT_GT(w["visible_wall_m"].get<double>(), 0.9 * w["wall_length_m"].get<double>());
  }
  EXPECT_THAT(names,
              ::testing::IsSupersetOf({"corridor", "loop", "office", "building", "cluttered"}));
}

}  // namespace
}  // namespace waymark::cli
