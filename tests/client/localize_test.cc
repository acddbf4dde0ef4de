// --localize-on SESSION [--initial-pose X,Y,THETA] on `slam replay` and `robot` against the
// in-memory fake SlamService: the CreateSession request they make, and the replay's account of
// the scans answered localized (the time to first fix).
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "client/cli/localize_flags.h"
#include "client/lib/channel.h"
#include "client/lib/slam_client.h"
#include "tests/client/carmen_test_log.h"
#include "tests/client/fake_slam_cli_test.h"
#include "tests/client/fake_slam_service.h"
#include "tests/client/test_util.h"

namespace waymark::cli {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
using waymark::testing::CliResult;
using waymark::testing::FakeSlamServer;
using waymark::testing::MakeLog;
using waymark::testing::ReadAll;
using waymark::testing::RunWaymark;
using waymark::testing::ScopedTempDir;

class LocalizeTest : public ::waymark::testing::FakeSlamCliTest {
 protected:
  // A stored map to localize on: an imported 2 x 2 grid, session s1.
  void SetUp() override {
    v1::OccupancyGrid grid;
    grid.set_width(2);
    grid.set_height(2);
    grid.set_resolution(0.05);
    grid.set_cells(std::string(4, '\0'));
    client::SlamClient client(client::MakeChannel(server_.address()));
    auto map = client.ImportMap("maps", "hall", grid);
    ASSERT_TRUE(map.ok()) << map.status();
    ASSERT_EQ(map->session_id(), "s1");
  }

};

TEST_F(LocalizeTest, ReplayCreatesALocalizationSessionAndReportsTheFirstFix) {
  server_.service().set_localized_from_scan(3);
  const auto out = dir_.path() / "o";
  CliResult r = Run({"--json", "slam", "replay", WriteLog(20), "--out", out.string(), "--localize-on",
                     "s1", "--initial-pose", "1.5,-2,0.3"});
  ASSERT_EQ(r.code, 0) << r.err;
  const v1::LaserSlamConfig laser = server_.service().last_create().laser();
  EXPECT_EQ(laser.localize().map_session_id(), "s1");
  EXPECT_DOUBLE_EQ(laser.localize().initial_pose().x(), 1.5);
  EXPECT_DOUBLE_EQ(laser.localize().initial_pose().y(), -2);
  EXPECT_DOUBLE_EQ(laser.localize().initial_pose().theta(), 0.3);
  EXPECT_EQ(laser.laser().beam_count(), 180u);  // the rest of the request is the replay's

  // Scans 3..20 of 20 (stamps 1000 + 0.2 i) are answered localized.
  const nlohmann::json localization = r.Json()["localization"];
  EXPECT_EQ(localization["map_session_id"], "s1");
  EXPECT_EQ(localization["localized_scans"], 18);
  EXPECT_EQ(localization["answers_with_status"], 20);
  EXPECT_EQ(localization["first_fix_scan"], 2);
  EXPECT_NEAR(localization["first_fix_stamp"].get<double>(), 1000.4, 1e-6);
  EXPECT_NEAR(localization["time_to_first_fix_s"].get<double>(), 0.4, 1e-6);
  // The fix's confidence, and the answers before it that another place made ambiguous.
  EXPECT_DOUBLE_EQ(localization["first_fix_score"].get<double>(), 0.8);
  EXPECT_DOUBLE_EQ(localization["first_fix_rival_ratio"].get<double>(), 0.5);
  EXPECT_DOUBLE_EQ(localization["first_fix_rival_distance_m"].get<double>(), 12.0);
  EXPECT_EQ(localization["ambiguous_answers"], 2);
  const nlohmann::json summary = nlohmann::json::parse(ReadAll(out / "summary.json"));
  EXPECT_EQ(summary["localization"], localization);

  CliResult human = Run(
      {"slam", "replay", WriteLog(20), "--out", (dir_.path() / "h").string(), "--localize-on", "s1"});
  ASSERT_EQ(human.code, 0) << human.err;
  EXPECT_THAT(human.out, HasSubstr("localization on map s1: 18 of 20 scans localized, first fix at "
                                   "scan 2 (stamp 1000.400, 0.40 s after the first scan) scoring "
                                   "0.80, its best rival 0.50 of that 12.0 m away; 2 answers "
                                   "refused a fix because another place fit nearly as well"));
  EXPECT_FALSE(server_.service().last_create().laser().localize().has_initial_pose());
}

// Issue 35: a localization replay draws the map it localized on (its grid, with the run's
// trajectory) and does not print the failure-looking "no occupancy grid for session ...: this
// session keeps no scans" of its own session.
TEST_F(LocalizeTest, ReplayDrawsTheMapItLocalizedOnWithItsTrajectory) {
  const auto out = dir_.path() / "o";
  CliResult human =
      Run({"slam", "replay", WriteLog(20), "--out", out.string(), "--localize-on", "s1"});
  ASSERT_EQ(human.code, 0) << human.err;
  EXPECT_THAT(human.out, Not(HasSubstr("no occupancy grid")));
  EXPECT_THAT(human.out, Not(HasSubstr("keeps no scans")));
  EXPECT_THAT(human.out, HasSubstr("the pictures show the map localized on, s1: its occupancy "
                                   "grid (2 x 2 cells of 0.05 m) and its 0 segments, with this "
                                   "run's trajectory"));
  // map.png is s1's grid under the trajectory: the very picture occupancy.png is (the session's
  // own segment map would be a titled picture of another size).
  const cv::Mat map = cv::imread((out / "map.png").string());
  const cv::Mat occupancy = cv::imread((out / "occupancy.png").string());
  ASSERT_FALSE(map.empty());
  ASSERT_FALSE(occupancy.empty());
  ASSERT_EQ(map.size(), occupancy.size());
  EXPECT_EQ(cv::norm(map, occupancy, cv::NORM_INF), 0);
  EXPECT_TRUE(std::filesystem::exists(out / "map.pgm"));

  CliResult r = Run({"--json", "slam", "replay", WriteLog(20), "--out",
                     (dir_.path() / "j").string(), "--localize-on", "s1"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.Json()["localization"]["drawn_map"], "s1");
  EXPECT_EQ(r.Json()["grid"]["width"], 2);
  EXPECT_FALSE(r.Json().contains("grid_note")) << r.out;
}

TEST_F(LocalizeTest, AReplayThatNeverLocalizesSaysSo) {
  server_.service().set_localized_from_scan(1000);
  CliResult r = Run({"--json", "slam", "replay", WriteLog(10), "--out", (dir_.path() / "o").string(),
                     "--localize-on", "s1"});
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json localization = r.Json()["localization"];
  EXPECT_EQ(localization["localized_scans"], 0);
  EXPECT_TRUE(localization["first_fix_scan"].is_null());
  EXPECT_TRUE(localization["time_to_first_fix_s"].is_null());
  CliResult human = Run(
      {"slam", "replay", WriteLog(10), "--out", (dir_.path() / "h").string(), "--localize-on", "s1"});
  EXPECT_THAT(human.out, HasSubstr("localization on map s1: 0 of 10 scans localized, never "
                                   "localized; 10 answers refused a fix because another place fit "
                                   "nearly as well (ambiguous)"));
}

TEST_F(LocalizeTest, AServerThatDoesNotLocalizeIsNotTakenForOneThatNeverLocalized) {
  server_.service().set_ignore_localize(true);  // older than LaserSlamConfig.localize: it maps
  CliResult r = Run({"--json", "slam", "replay", WriteLog(10), "--out", (dir_.path() / "o").string(),
                     "--localize-on", "s1"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.Json()["localization"]["answers_with_status"], 0);
  CliResult human = Run(
      {"slam", "replay", WriteLog(10), "--out", (dir_.path() / "h").string(), "--localize-on", "s1"});
  EXPECT_THAT(human.out, HasSubstr("0 of 10 scans localized: no answer carried a localization "
                                   "status (a server older than --localize-on maps instead)"));
}

TEST_F(LocalizeTest, AMappingReplayHasNoLocalizationReport) {
  CliResult r = Run({"--json", "slam", "replay", WriteLog(5), "--out", (dir_.path() / "o").string()});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_FALSE(r.Json().contains("localization"));
  EXPECT_FALSE(server_.service().last_create().laser().has_localize());
}

TEST_F(LocalizeTest, ReplayArgumentAndServerErrors) {
  CliResult no_map = Run({"slam", "replay", WriteLog(5), "--initial-pose", "1,2,0"});
  EXPECT_NE(no_map.code, 0);
  EXPECT_THAT(no_map.err, HasSubstr("--initial-pose needs --localize-on"));
  CliResult bad_pose =
      Run({"slam", "replay", WriteLog(5), "--localize-on", "s1", "--initial-pose", "1,2"});
  EXPECT_NE(bad_pose.code, 0);
  EXPECT_THAT(bad_pose.err, HasSubstr("expected X,Y,THETA"));
  EXPECT_EQ(server_.service().scans_received(), 0);

  CliResult unknown = Run({"slam", "replay", WriteLog(5), "--localize-on", "nowhere"});
  EXPECT_EQ(unknown.code, 1);
  EXPECT_THAT(unknown.err, HasSubstr("NOT_FOUND"));
  EXPECT_THAT(unknown.err, HasSubstr("(CreateSession)"));
}

TEST_F(LocalizeTest, RobotCreatesALocalizationSession) {
  CliResult r =
      Run({"robot", "--base", "sim:office", "--laser", "sim", "--duration", "1", "--sim-speed",
           "10", "--robot-id", "r1", "--localize-on", "s1", "--initial-pose", "0.5,0.25,-1"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("localizing on map s1"));
  const v1::CreateSessionRequest create = server_.service().last_create();
  EXPECT_EQ(create.robot_id(), "r1");
  EXPECT_EQ(create.laser().localize().map_session_id(), "s1");
  EXPECT_DOUBLE_EQ(create.laser().localize().initial_pose().theta(), -1);
  EXPECT_EQ(create.laser().laser().beam_count(), 181u);
}

TEST_F(LocalizeTest, RobotCannotLocalizeAResumedSession) {
  CliResult r = Run(
      {"robot", "--base", "sim:office", "--laser", "sim", "--resume", "s1", "--localize-on", "s1"});
  EXPECT_NE(r.code, 0);
  EXPECT_THAT(r.err, HasSubstr("excludes"));
}

TEST(PoseTextTest, ParsesThreeNumbersAndNothingElse) {
  auto pose = ParsePoseText("1.5,-2,0.3");
  ASSERT_TRUE(pose.ok()) << pose.status();
  EXPECT_DOUBLE_EQ(pose->x(), 1.5);
  EXPECT_DOUBLE_EQ(pose->y(), -2);
  EXPECT_DOUBLE_EQ(pose->theta(), 0.3);
  for (const std::string bad : {"1,2", "1,2,3,4", "a,b,c", "nan,0,0", "", "1,,2"}) {
    SCOPED_TRACE(bad);
    auto parsed = ParsePoseText(bad);
    EXPECT_EQ(parsed.status().code(), absl::StatusCode::kInvalidArgument);
    EXPECT_THAT(std::string(parsed.status().message()), HasSubstr("'" + bad + "'"));
  }
}

}  // namespace
}  // namespace waymark::cli
