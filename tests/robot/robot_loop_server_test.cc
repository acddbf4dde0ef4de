// The robot loop end to end: the Pioneer and LMS200 drivers over pseudo-terminals to the fake
// ARCOS controller and the fake LMS200, streaming into the real waymark-server; a server killed
// under a driving robot must stop it, and the loop must resume the same session once the server
// is back. Also `waymark robot` itself, on the serial fakes and on the simulator.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cmath>
#include <csignal>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <thread>

#include "absl/time/clock.h"
#include "client/devices/lms200_scanner.h"
#include "client/devices/pioneer_base.h"
#include "client/lib/channel.h"
#include "client/robot/robot_loop.h"
#include "tests/robot/eventually.h"
#include "tests/robot/fake_arcos_peer.h"
#include "tests/robot/fake_lms200_peer.h"
#include "tests/support/server_process.h"
#include "tests/support/synthetic_scene.h"

namespace waymark::cli {
namespace {

using testing::FakeArcosPeer;
using testing::FakeLms200Options;
using testing::FakeLms200Peer;
using ::testing::HasSubstr;
using testing::PtyPair;
using testing::ServerProcess;

using testing::Eventually;

class RobotLoopServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = testing::MakeTempDir("robot-loop");
    db_ = dir_ + "/waymark.db";
    auto server = ServerProcess::Start(testing::ServerBinary(), db_);
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = *std::move(server);
    auto pty = PtyPair::Open();
    ASSERT_TRUE(pty.ok()) << pty.status();
    robot_ = std::make_unique<FakeArcosPeer>(*std::move(pty));
    FakeLms200Options laser_options;
    laser_options.scan_period = absl::Milliseconds(100);
    laser_options.range_mm = testing::RoomRangeMm;
    auto laser = FakeLms200Peer::Start(laser_options);
    ASSERT_TRUE(laser.ok()) << laser.status();
    laser_ = *std::move(laser);
  }

  void ConnectDevices() {
    auto base = adapters::PioneerBase::Connect(robot_->device_path());
    ASSERT_TRUE(base.ok()) << base.status();
    base_ = *std::move(base);
    auto scanner = adapters::Lms200Scanner::Connect(laser_->device_path());
    ASSERT_TRUE(scanner.ok()) << scanner.status();
    scanner_ = *std::move(scanner);
    client_ = std::make_unique<client::SlamClient>(client::MakeChannel(server_->address()));
  }

  std::string dir_, db_;
  std::unique_ptr<ServerProcess> server_;
  std::unique_ptr<FakeArcosPeer> robot_;
  std::unique_ptr<FakeLms200Peer> laser_;
  std::unique_ptr<adapters::PioneerBase> base_;
  std::unique_ptr<adapters::Lms200Scanner> scanner_;
  std::unique_ptr<client::SlamClient> client_;
  std::atomic<bool> stop_{false};
};

TEST_F(RobotLoopServerTest, PassiveOverSerialMapsTheRoomAndNeverMovesTheRobot) {
  ConnectDevices();
  RobotLoopOptions options;
  options.robot_id = "pioneer";
  options.duration_s = 2;
  RobotLoop loop(*client_, *base_, *scanner_, options);
  auto status = loop.Run(stop_);
  ASSERT_TRUE(status.ok()) << status.status() << "\n" << server_->Log();
  EXPECT_GE(status->scans_answered, 8u);  // 10 Hz for 2 s, minus connect jitter
  EXPECT_EQ(status->scans_rejected, 0u);
  EXPECT_GE(status->segments, 3);  // the room's walls
  EXPECT_FALSE(robot_->ever_moved());
}

TEST_F(RobotLoopServerTest, AKilledServerStopsTheDrivingRobotAndTheLoopResumesTheSession) {
  ConnectDevices();
  RobotLoopOptions options;
  options.robot_id = "pioneer";
  options.mode = DriveMode::kActive;
  options.reconnect_initial = absl::Milliseconds(100);
  options.reconnect_max = absl::Milliseconds(500);
  RobotLoop loop(*client_, *base_, *scanner_, options);
  std::vector<std::string> events;
  std::mutex events_mutex;
  loop.set_event_callback([&](const std::string& e) {
    std::lock_guard<std::mutex> lock(events_mutex);
    events.push_back(e);
  });
  absl::StatusOr<RobotStatus> result;
  std::thread runner([&] { result = loop.Run(stop_); });

  // Driving a suggestion: the robot got a non-zero velocity.
  const bool moved = Eventually([&] { return robot_->ever_moved(); }, absl::Seconds(20));
  EXPECT_TRUE(moved) << server_->Log();
  const uint64_t answered_before = loop.status().scans_answered;
  const std::string session = loop.status().session_id;
  const std::string address = server_->address();
  server_->Stop(SIGKILL);
  // The robot must be told to stop (VEL 0, RVEL 0) and stay stopped while the server is down.
  EXPECT_TRUE(Eventually([&] {
    return robot_->last_velocities() == std::make_pair(0, 0) &&
           loop.status().stops[static_cast<int>(StopReason::kStreamBroken)] > 0;
  }));
  absl::SleepFor(absl::Milliseconds(500));
  EXPECT_EQ(robot_->last_velocities(), std::make_pair(0, 0));
  EXPECT_FALSE(loop.status().server_connected);

  auto restarted = ServerProcess::Start(testing::ServerBinary(), db_, {}, address);
  ASSERT_TRUE(restarted.ok()) << restarted.status();
  server_ = *std::move(restarted);
  EXPECT_TRUE(Eventually([&] { return loop.status().scans_answered >= answered_before + 2; },
                         absl::Seconds(30)))
      << server_->Log();
  stop_ = true;
  runner.join();
  ASSERT_TRUE(result.ok()) << result.status() << "\n" << server_->Log();
  EXPECT_EQ(result->session_id, session);
  EXPECT_GE(result->reconnects, 1u);
  auto sessions = client_->ListSessions("pioneer");
  ASSERT_TRUE(sessions.ok()) << sessions.status();
  EXPECT_EQ(sessions->sessions_size(), 1);
  EXPECT_EQ(robot_->last_velocities(), std::make_pair(0, 0));
}

// Runs the waymark binary of this build; returns (exit code, stdout, stderr).
struct BinaryRun {
  int code = -1;
  std::string out, err;
};
// `input`: a shell command whose output is piped to waymark's stdin (the teleop keyboard).
BinaryRun RunWaymarkBinary(const std::string& server, const std::vector<std::string>& args,
                           const std::string& dir, const std::string& input = "") {
  std::string command = (input.empty() ? "" : "(" + input + ") | ") +
                        std::string(WAYMARK_BINARY_DIR) + "/bin/waymark --server " + server;
  for (const auto& a : args) command += " '" + a + "'";
  const std::string out = dir + "/out.txt", err = dir + "/err.txt";
  command += " >" + out + " 2>" + err;
  BinaryRun r;
  const int status = std::system(command.c_str());
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  auto slurp = [](const std::string& path) {
    std::string text;
    if (FILE* f = std::fopen(path.c_str(), "r")) {
      char buffer[4096];
      size_t n;
      while ((n = std::fread(buffer, 1, sizeof(buffer), f)) > 0) text.append(buffer, n);
      std::fclose(f);
    }
    return text;
  };
  r.out = slurp(out);
  r.err = slurp(err);
  return r;
}

TEST_F(RobotLoopServerTest, CommandOnTheSerialFakes) {
  BinaryRun r = RunWaymarkBinary(server_->address(),
                                 {"robot", "--base", "serial:" + robot_->device_path(), "--laser",
                                  "serial:" + laser_->device_path(), "--duration", "1.5", "--json"},
                                 dir_);
  ASSERT_EQ(r.code, 0) << r.err << r.out;
  const nlohmann::json summary = nlohmann::json::parse(r.out);
  EXPECT_EQ(summary["mode"], "passive");
  EXPECT_GE(summary["scans_answered"].get<int>(), 5);
  EXPECT_THAT(summary["devices"].get<std::string>(), HasSubstr("181 beams"));
  EXPECT_THAT(r.err, HasSubstr("server=ok"));
  // The drivers said goodbye: the laser stopped streaming, the robot connection was closed.
  EXPECT_TRUE(Eventually([&] { return !robot_->is_open(); }));
}

TEST_F(RobotLoopServerTest, CommandDrivesTheSimulatorThroughTheRealServerWithoutCollisions) {
  BinaryRun r = RunWaymarkBinary(server_->address(),
                                 {"robot", "--base", "sim:office", "--laser", "sim", "--mode",
                                  "active", "--duration", "40", "--sim-speed", "10", "--json"},
                                 dir_);
  ASSERT_EQ(r.code, 0) << r.err << r.out;
  const nlohmann::json summary = nlohmann::json::parse(r.out);
  EXPECT_GE(summary["suggestions_driven"].get<int>(), 5);
  EXPECT_GT(summary["sim"]["distance_m"].get<double>(), 0.3);
  EXPECT_EQ(summary["sim"]["collisions"].get<int>(), 0);
  EXPECT_EQ(summary["safety_stops"]["server stream broken"].get<int>(), 0);
  EXPECT_GE(summary["segments"].get<int>(), 5);
}

TEST_F(RobotLoopServerTest, CtrlCStopsTheRobotClosesTheSessionAndExitsCleanly) {
  const std::string out = dir_ + "/sigint.json", err = dir_ + "/sigint.err";
  const std::string command =
      std::string(WAYMARK_BINARY_DIR) + "/bin/waymark --server " + server_->address() +
      " robot --base sim:office --laser sim --mode active --sim-speed 10 --json >" + out + " 2>" +
      err + " & pid=$!; sleep 2; kill -INT $pid; wait $pid";
  const int status = std::system(("sh -c '" + command + "'").c_str());
  ASSERT_TRUE(WIFEXITED(status));
  std::ifstream in(out);
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_EQ(WEXITSTATUS(status), 0) << text.str();
  const nlohmann::json summary = nlohmann::json::parse(text.str());
  EXPECT_EQ(summary["safety_stops"]["shutdown"].get<int>(), 1);
  EXPECT_GE(summary["suggestions_driven"].get<int>(), 1);
  auto sessions = client::SlamClient(client::MakeChannel(server_->address())).ListSessions();
  ASSERT_TRUE(sessions.ok());
  ASSERT_EQ(sessions->sessions_size(), 1);
  EXPECT_EQ(sessions->sessions(0).state(), v1::Session::CLOSED);
}

TEST_F(RobotLoopServerTest, TeleopDrivesWithKeysAndQuitsOnQ) {
  // Two presses of w (0.1 m/s), 1 s of driving (10 s simulated), then q.
  BinaryRun r = RunWaymarkBinary(server_->address(),
                                 {"robot", "--base", "sim:office", "--laser", "sim", "--mode",
                                  "teleop", "--sim-speed", "10", "--json"},
                                 dir_, "printf ww; sleep 1; printf q");
  ASSERT_EQ(r.code, 0) << r.err << r.out;
  EXPECT_THAT(r.err, HasSubstr("teleop: w/s"));
  const nlohmann::json summary = nlohmann::json::parse(r.out);
  EXPECT_EQ(summary["mode"], "teleop");
  // At most ~10 s at 0.1 m/s (less on a slow machine, where the robot starts later); the office's
  // start leaves room ahead.
  EXPECT_GT(summary["sim"]["distance_m"].get<double>(), 0.05);
  EXPECT_LT(summary["sim"]["distance_m"].get<double>(), 1.6);
  EXPECT_EQ(summary["sim"]["collisions"].get<int>(), 0);
  // Keys re-sent while held: the watchdog never had to stop a live command.
  EXPECT_EQ(summary["safety_stops"]["command expired"].get<int>(), 0);
}

TEST_F(RobotLoopServerTest, TeleopStopsWhenTheKeyboardGoesAway) {
  BinaryRun r = RunWaymarkBinary(server_->address(),
                                 {"robot", "--base", "sim:office", "--laser", "sim", "--mode",
                                  "teleop", "--sim-speed", "10", "--duration", "20", "--json"},
                                 dir_, "printf ww");
  ASSERT_EQ(r.code, 0) << r.err << r.out;
  EXPECT_THAT(r.err, HasSubstr("no more keyboard input"));
  const nlohmann::json summary = nlohmann::json::parse(r.out);
  EXPECT_LT(summary["sim"]["distance_m"].get<double>(), 0.2);  // 20 s at 0.1 m/s would be 2 m
}

TEST_F(RobotLoopServerTest, CommandRecognizesTheCrossingFromTheCamera) {
  // One crossing enrolled from four views of a synthetic panorama; the "camera" is an image
  // sequence of one of those views seen again.
  namespace fs = std::filesystem;
  const cv::Mat panorama = testing::MakePanorama(/*seed=*/42);
  const fs::path enroll_dir = fs::path(dir_) / "enroll" / "K3";
  fs::create_directories(enroll_dir);
  for (int heading : {0, 90, 180, 270}) {
    cv::imwrite((enroll_dir / (std::to_string(heading) + ".png")).string(),
                testing::CropView(panorama, heading));
  }
  const fs::path camera_dir = fs::path(dir_) / "camera";
  fs::create_directories(camera_dir);
  for (int i = 0; i < 2; ++i) {
    cv::imwrite((camera_dir / ("frame" + std::to_string(i) + ".png")).string(),
                testing::CropView(panorama, 92));
  }
  ASSERT_EQ(RunWaymarkBinary(server_->address(), {"db", "create", "streets"}, dir_).code, 0);
  BinaryRun enrolled = RunWaymarkBinary(
      server_->address(), {"enroll", "streets", (fs::path(dir_) / "enroll").string()}, dir_);
  ASSERT_EQ(enrolled.code, 0) << enrolled.err;

  BinaryRun r =
      RunWaymarkBinary(server_->address(),
                       {"robot", "--base", "sim:office", "--laser", "sim", "--duration", "40",
                        "--sim-speed", "10", "--camera", (camera_dir / "frame%d.png").string(),
                        "--crossings", "streets", "--recognize-every", "0.5"},
                       dir_);
  ASSERT_EQ(r.code, 0) << r.err << r.out;
  EXPECT_THAT(r.out, HasSubstr("crossing: K3 (heading 90 deg"));
  EXPECT_THAT(r.out, HasSubstr("crossing=K3"));
  EXPECT_THAT(r.out, HasSubstr("stopped: session"));

  BinaryRun unknown =
      RunWaymarkBinary(server_->address(),
                       {"robot", "--base", "sim:office", "--laser", "sim", "--camera",
                        (camera_dir / "frame%d.png").string(), "--crossings", "nowhere"},
                       dir_);
  EXPECT_NE(unknown.code, 0);
  EXPECT_THAT(unknown.err, HasSubstr("crossing database 'nowhere' not found"));
}

}  // namespace
}  // namespace waymark::cli
