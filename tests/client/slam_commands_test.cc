// `waymark slam ...` and `waymark eval relations` against the in-memory fake SlamService, and the
// SensorStream's flow control.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "client/lib/channel.h"
#include "client/lib/slam_client.h"
#include "client/cli/cli.h"
#include "client/sessions/slam_replay.h"
#include "client/datasets/tum_trajectory.h"
#include "tests/client/carmen_test_log.h"
#include "tests/client/fake_slam_cli_test.h"
#include "tests/client/fake_slam_service.h"
#include "tests/client/test_util.h"

namespace waymark::cli {
namespace {

using ::testing::HasSubstr;
using waymark::testing::CliResult;
using waymark::testing::FakeSlamServer;
using waymark::testing::MakeLog;
using waymark::testing::ReadAll;
using waymark::testing::RunWaymark;
using waymark::testing::ScopedTempDir;

int Count(const std::string& text, const std::string& what) {
  int n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

int PoseLines(const std::filesystem::path& path) {
  std::istringstream in(ReadAll(path));
  int n = 0;
  for (std::string line; std::getline(in, line);) n += !line.empty() && line[0] != '#';
  return n;
}

using SlamCliTest = ::waymark::testing::FakeSlamCliTest;

TEST_F(SlamCliTest, ReplayOdometryLagIsTakenAsGivenAndCheckedAndRecorded) {
  const std::string log = WriteLog(20);
  const auto out = dir_.path() / "out";
  CliResult r = Run({"--json", "slam", "replay", log, "--out", out.string(), "--odometry-lag", "-1"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.Json()["odometry_lag_scans"], -1);
  for (const char* bad : {"x", "1.5", "101", ""}) {
    CliResult refused = Run({"slam", "replay", log, "--out", out.string(), "--odometry-lag", bad});
    EXPECT_NE(refused.code, 0) << bad;
    EXPECT_THAT(refused.err, HasSubstr("--odometry-lag")) << bad;
  }
}

TEST_F(SlamCliTest, ReplayStreamsEveryScanWithinTheWindowAndWritesTheOutputs) {
  server_.service().set_scan_delay(absl::Milliseconds(2));
  // Nothing is answered before the window is full: the window is used on any machine.
  server_.service().set_hold_until_received(4);
  const std::string log = WriteLog(100);
  const auto out = dir_.path() / "out";
  CliResult r = Run({"--json", "slam", "replay", log, "--out", out.string(), "--window", "4",
                     "--robot", "r2", "--max-range", "5.5", "--match-chi2", "7"});
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json json = r.Json();
  EXPECT_EQ(json["scans"], 100);
  EXPECT_EQ(json["scans_sent"], 100);
  EXPECT_EQ(json["skipped_stamps"], 1);
  EXPECT_EQ(json["malformed_lines"], 1);
  EXPECT_EQ(json["rejected"], 0);
  EXPECT_EQ(json["segments"], 10);
  EXPECT_EQ(json["odometry_lines_not_sent"], 100);
  EXPECT_EQ(json["odometry_lag_scans"], 0) << "a log with no turns keeps its pairing";
  EXPECT_NEAR(json["log_duration_s"].get<double>(), 19.8, 1e-6);
  EXPECT_GT(json["processing_s"].get<double>(), 0);
  EXPECT_NEAR(json["realtime_factor"].get<double>(),
              19.8 / json["processing_s"].get<double>(), 1e-6);
  EXPECT_EQ(json["session_id"], "s1");
  EXPECT_LE(json["max_outstanding"].get<int>(), 4);
  EXPECT_THAT(r.err, HasSubstr("line 46: FLASER: expected 191 fields, got 7"));

  // The fake never held more than the window, and the window was used.
  EXPECT_LE(server_.service().max_outstanding_scans(), 4);
  EXPECT_GE(server_.service().max_outstanding_scans(), 2);
  EXPECT_EQ(server_.service().scans_received(), 100);
  EXPECT_EQ(server_.service().odometry_received(), 100);
  EXPECT_EQ(server_.service().rejected(), 0);

  const v1::CreateSessionRequest create = server_.service().last_create();
  EXPECT_EQ(create.robot_id(), "r2");
  EXPECT_EQ(create.laser().laser().beam_count(), 180u);
  EXPECT_NEAR(create.laser().laser().angle_min(), -1.5707963, 1e-6);
  EXPECT_DOUBLE_EQ(create.laser().params().max_range(), 5.5);
  EXPECT_DOUBLE_EQ(create.laser().params().match_chi2(), 7);
  EXPECT_FALSE(create.laser().params().has_odom_xy_per_m());

  EXPECT_EQ(PoseLines(out / "trajectory.txt"), 100);
  auto trajectory = ReadTumFile(out / "trajectory.txt");
  ASSERT_TRUE(trajectory.ok());
  EXPECT_NEAR(trajectory->back().pose.x, 9.9, 1e-6);  // the fake's pose is the odometry
  EXPECT_NEAR(trajectory->front().stamp, 1000.0, 1e-6);
  EXPECT_EQ(Count(ReadAll(out / "map.svg"), "class=\"segment "), 10);
  EXPECT_FALSE(cv::imread((out / "map.png").string()).empty());
  const nlohmann::json summary = nlohmann::json::parse(ReadAll(out / "summary.json"));
  EXPECT_EQ(summary["scans"], 100);
}

TEST_F(SlamCliTest, ReplayMaxScansAndHumanOutput) {
  const std::string log = WriteLog(50);
  CliResult r = Run({"slam", "replay", log, "--out", (dir_.path() / "o").string(), "--max-scans",
                     "7"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("7 scans processed"));
  EXPECT_THAT(r.out, HasSubstr("real-time factor"));
  EXPECT_EQ(PoseLines(dir_.path() / "o" / "trajectory.txt"), 7);
}

TEST_F(SlamCliTest, ReplayErrors) {
  CliResult missing = Run({"slam", "replay", (dir_.path() / "none.clf").string()});
  EXPECT_EQ(missing.code, 1);
  EXPECT_THAT(missing.err, HasSubstr("NOT_FOUND"));
  const auto empty = dir_.path() / "empty.clf";
  std::ofstream(empty) << "# nothing\nODOM 0 0 0 0 0 0 1.0 nohost 0\n";
  CliResult no_laser = Run({"slam", "replay", empty.string()});
  EXPECT_EQ(no_laser.code, 1);
  EXPECT_THAT(no_laser.err, HasSubstr("no laser lines"));
}

TEST_F(SlamCliTest, SessionCommands) {
  const std::string log = WriteLog(20);
  ASSERT_EQ(Run({"slam", "replay", log, "--out", (dir_.path() / "a").string()}).code, 0);
  CliResult list = Run({"--json", "slam", "list"});
  ASSERT_EQ(list.code, 0) << list.err;
  ASSERT_EQ(list.Json()["sessions"].size(), 1u);
  EXPECT_EQ(list.Json()["sessions"][0]["robot_id"], "replay");
  EXPECT_THAT(Run({"slam", "list"}).out, HasSubstr("closed"));
  EXPECT_THAT(Run({"slam", "list", "--robot", "other"}).out, HasSubstr("no sessions"));

  CliResult trajectory = Run({"slam", "trajectory", "s1"});
  ASSERT_EQ(trajectory.code, 0);
  auto poses = ParseTum(trajectory.out);
  ASSERT_TRUE(poses.ok());
  EXPECT_EQ(poses->size(), 20u);

  const auto map_dir = dir_.path() / "map";
  CliResult map = Run({"--json", "slam", "map", "s1", "--out", map_dir.string()});
  ASSERT_EQ(map.code, 0) << map.err;
  EXPECT_EQ(map.Json()["segments"], 2);
  EXPECT_EQ(Count(ReadAll(map_dir / "map.svg"), "class=\"segment "), 2);
  EXPECT_FALSE(cv::imread((map_dir / "map.png").string()).empty());

  CliResult unknown = Run({"slam", "close", "nope"});
  EXPECT_EQ(unknown.code, 1);
  EXPECT_THAT(unknown.err, HasSubstr("NOT_FOUND"));
}

TEST_F(SlamCliTest, ClosingASessionTheReplayClosedIsAQuietSuccess) {
  ASSERT_EQ(Run({"slam", "replay", WriteLog(20), "--out", (dir_.path() / "a").string()}).code, 0);
  // The server refuses a second close (FAILED_PRECONDITION); the command says what is true.
  CliResult again = Run({"slam", "close", "s1"});
  EXPECT_EQ(again.code, 0) << again.err;
  EXPECT_THAT(again.out, HasSubstr("session s1 is already closed: 20 scans"));
  CliResult json = Run({"--json", "slam", "close", "s1"});
  ASSERT_EQ(json.code, 0) << json.err;
  EXPECT_EQ(json.Json()["already_closed"], true);
  EXPECT_EQ(json.Json()["state"], "closed");
}

TEST_F(SlamCliTest, CloseClosesAnOpenSession) {
  client::SlamClient client(client::MakeChannel(server_.address()));
  v1::CreateSessionRequest create;
  create.mutable_laser()->mutable_laser()->set_beam_count(3);
  ASSERT_TRUE(client.CreateSession(create).ok());
  CliResult r = Run({"--json", "slam", "close", "s1"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.Json()["already_closed"], false);
  EXPECT_THAT(Run({"slam", "close", "s1"}).out, HasSubstr("already closed"));
}

TEST_F(SlamCliTest, DeleteNeedsForceForAnOpenSessionAndSaysWhatWent) {
  client::SlamClient client(client::MakeChannel(server_.address()));
  v1::CreateSessionRequest create;
  create.mutable_laser()->mutable_laser()->set_beam_count(3);
  create.set_robot_id("r7");
  ASSERT_TRUE(client.CreateSession(create).ok());  // s1, open
  ASSERT_EQ(Run({"slam", "replay", WriteLog(20), "--out", (dir_.path() / "a").string()}).code, 0);

  CliResult open = Run({"slam", "delete", "s1"});
  EXPECT_EQ(open.code, 1);
  EXPECT_THAT(open.err, HasSubstr("FAILED_PRECONDITION"));
  EXPECT_THAT(open.err, HasSubstr("waymark slam delete s1 --force"));
  CliResult forced = Run({"slam", "delete", "s1", "--force"});
  ASSERT_EQ(forced.code, 0) << forced.err;
  EXPECT_THAT(forced.out, HasSubstr("deleted session s1 (robot r7)"));
  EXPECT_THAT(forced.out, HasSubstr("it was open and was closed first"));

  CliResult replayed = Run({"--json", "slam", "delete", "s2"});
  ASSERT_EQ(replayed.code, 0) << replayed.err;
  EXPECT_EQ(replayed.Json()["trajectory_poses"], 20);
  EXPECT_EQ(replayed.Json()["session"]["session_id"], "s2");
  EXPECT_THAT(Run({"slam", "list"}).out, HasSubstr("no sessions"));
  CliResult unknown = Run({"slam", "delete", "s2"});
  EXPECT_EQ(unknown.code, 1);
  EXPECT_THAT(unknown.err, HasSubstr("NOT_FOUND"));
}

TEST_F(SlamCliTest, MapOutNamingAPictureWritesOnlyThatPicture) {
  ASSERT_EQ(Run({"slam", "replay", WriteLog(20), "--out", (dir_.path() / "a").string()}).code, 0);
  const auto folder = dir_.path() / "pictures";
  CliResult svg = Run({"slam", "map", "s1", "--out", (folder / "map.svg").string()});
  ASSERT_EQ(svg.code, 0) << svg.err;
  EXPECT_TRUE(std::filesystem::is_regular_file(folder / "map.svg"));
  EXPECT_EQ(Count(ReadAll(folder / "map.svg"), "class=\"segment "), 2);
  CliResult png = Run({"--json", "slam", "map", "s1", "--out", (folder / "map.png").string()});
  ASSERT_EQ(png.code, 0) << png.err;
  EXPECT_FALSE(cv::imread((folder / "map.png").string()).empty());
  EXPECT_EQ(png.Json()["files"].size(), 1u);
  EXPECT_EQ(png.Json()["out"], (folder / "map.png").string());
  // Only the two pictures: no trajectory.txt, no folder named map.svg.
  EXPECT_EQ(std::distance(std::filesystem::directory_iterator(folder),
                          std::filesystem::directory_iterator()),
            2);
}

TEST_F(SlamCliTest, OdometryThenEvalRelations) {
  const std::string log = WriteLog(30);
  const auto odometry = dir_.path() / "odom.txt";
  CliResult r = Run({"slam", "odometry", log, "--out", odometry.string()});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(PoseLines(odometry), 30);

  // Relations that the odometry satisfies exactly, one 5 cm off, one at a stamp with no pose.
  const auto relations = dir_.path() / "test.relations";
  std::ofstream(relations) << "1000.000000 1000.200000 0.1 0 0 0 0 0\n"
                              "1000.200000 1001.000000 0.45 0 0 0 0 0\n"
                              "1000.200000 1777.0 0.45 0 0 0 0 0\n";
  CliResult eval = Run({"--json", "eval", "relations", odometry.string(), relations.string()});
  ASSERT_EQ(eval.code, 0) << eval.err;
  const nlohmann::json json = eval.Json();
  EXPECT_EQ(json["relations"], 3);
  EXPECT_EQ(json["relations_used"], 2);
  EXPECT_NEAR(json["trans_abs_mean"].get<double>(), 0.025, 1e-6);
  EXPECT_NEAR(json["trans_abs_std"].get<double>(), 0.025, 1e-6);
  EXPECT_NEAR(json["rot_abs_mean_deg"].get<double>(), 0, 1e-9);
  EXPECT_THAT(eval.err, HasSubstr("1 of 3 relations had no pose"));

  CliResult human = Run({"eval", "relations", odometry.string(), relations.string()});
  EXPECT_THAT(human.out, HasSubstr("3 (2 used, 1 without a pose"));
  // The recognition `eval` keeps its own arguments.
  CliResult plain_eval = Run({"eval"});
  EXPECT_EQ(plain_eval.code, 1);
  EXPECT_THAT(plain_eval.err, HasSubstr("eval needs NAME and QUERY_DIR"));
}

TEST_F(SlamCliTest, LaserLinesAreReorderedByStamp) {
  // Stamps 1, 3, 2, 4, 4: the 2 is reordered, the second 4 is a duplicate and skipped.
  const auto log = dir_.path() / "shuffled.clf";
  {
    std::ofstream out(log);
    for (double t : {1.0, 3.0, 2.0, 4.0, 4.0}) {
      out << "FLASER 3 1 1 1 " << t << " 0 0 " << t << " 0 0 " << t << " nohost 0\n";
    }
  }
  const auto odometry = dir_.path() / "odom.txt";
  CliResult r = Run({"--json", "slam", "odometry", log.string(), "--out", odometry.string()});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.Json()["poses"], 4);
  EXPECT_EQ(r.Json()["reordered_lines"], 1);
  EXPECT_EQ(r.Json()["skipped_stamps"], 1);
  auto poses = ReadTumFile(odometry);
  ASSERT_TRUE(poses.ok());
  ASSERT_EQ(poses->size(), 4u);
  for (int i = 0; i < 4; ++i) {
    EXPECT_DOUBLE_EQ((*poses)[i].stamp, i + 1.0);
    EXPECT_NEAR((*poses)[i].pose.x, i + 1.0, 1e-9);  // each pose stays with its own stamp
  }
}

TEST(LogName, StripsLogExtensions) {
  EXPECT_EQ(LogName("/data/aces/aces.clf.bz2"), "aces");
  EXPECT_EQ(LogName("intel-corrected.log.gz"), "intel-corrected");
  EXPECT_EQ(LogName("run.clf"), "run");
}

// Flow control matters: against a small, slow queue an unwindowed sender overflows it and a
// windowed one never does.
TEST(SensorStreamTest, WindowKeepsTheServerQueueFromOverflowing) {
  FakeSlamServer server;
  server.service().set_scan_delay(absl::Milliseconds(3));
  server.service().set_queue_capacity(8);
  client::SlamClient client(client::MakeChannel(server.address()));
  v1::CreateSessionRequest create;
  create.mutable_laser()->mutable_laser()->set_beam_count(3);

  for (const int window : {3, 1000}) {
    SCOPED_TRACE(window);
    // Without a window, nothing is processed before the 12th message: the client has then
    // overflowed the queue of 8, however quickly this machine runs the fake's worker. (With a
    // window of 3 the client waits for answers after 3 messages: no hold.)
    server.service().set_hold_until_received(window == 1000 ? 12 : 0);
    auto session = client.CreateSession(create);
    ASSERT_TRUE(session.ok());
    std::atomic<int> answers{0};
    auto stream = client.StreamSensorData(session->session_id(), window,
                                          [&](const v1::SlamUpdate&) { ++answers; });
    for (int i = 0; i < 60; ++i) {
      v1::LaserScan scan;
      scan.set_stamp(1.0 + i);
      scan.add_ranges(1);
      scan.add_ranges(2);
      scan.add_ranges(3);
      ASSERT_TRUE(stream->SendScan(scan).ok());
      EXPECT_LE(stream->outstanding(), window);
    }
    ASSERT_TRUE(stream->Finish().ok());
    const client::SensorStream::Stats stats = stream->stats();
    EXPECT_EQ(stats.scans_sent, 60u);
    EXPECT_EQ(answers.load(), 60);
    EXPECT_EQ(stats.updates + stats.scans_rejected, 60u);
    if (window == 3) {
      EXPECT_EQ(stats.queue_full, 0u);
      EXPECT_EQ(stats.updates, 60u);
      EXPECT_LE(stats.max_outstanding, 3);
    } else {
      EXPECT_GT(stats.queue_full, 0u);  // what the window prevents
    }
  }
}

TEST(SensorStreamTest, RejectionsCountAsAnswers) {
  FakeSlamServer server;
  client::SlamClient client(client::MakeChannel(server.address()));
  v1::CreateSessionRequest create;
  create.mutable_laser()->mutable_laser()->set_beam_count(1);
  auto session = client.CreateSession(create);
  ASSERT_TRUE(session.ok());
  auto stream = client.StreamSensorData(session->session_id(), 2);
  for (int i = 0; i < 10; ++i) {
    v1::LaserScan scan;
    scan.set_stamp(5.0);  // only the first is accepted
    scan.add_ranges(1);
    ASSERT_TRUE(stream->SendScan(scan).ok());
  }
  ASSERT_TRUE(stream->Finish().ok());
  EXPECT_EQ(stream->stats().updates, 1u);
  EXPECT_EQ(stream->stats().scans_rejected, 9u);
}

}  // namespace
}  // namespace waymark::cli
