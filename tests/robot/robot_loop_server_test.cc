// The robot loop end to end: the Pioneer and LMS200 drivers over pseudo-terminals to the fake
// ARCOS controller and the fake LMS200, streaming into the real waymark-server; a server killed
// under a driving robot must stop it, and the loop must resume the same session once the server
// is back. Also `waymark robot` itself, on the serial fakes and on the simulator.
//
// No test here depends on how fast the machine is: runs end when what they wait for has happened
// (scans answered, a status line, commands seen by the fake robot), never after an amount of
// wall-clock time in which something is expected to have happened; the timeouts only turn a hang
// into a failure.
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
#include <optional>
#include <thread>

#include "absl/time/clock.h"
#include "client/devices/lms200_scanner.h"
#include "client/devices/pioneer_base.h"
#include "client/lib/channel.h"
#include "client/robot/robot_loop.h"
#include "tests/robot/eventually.h"
#include "tests/robot/fake_arcos_peer.h"
#include "tests/robot/fake_lms200_peer.h"
#include "tests/support/child_process.h"
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

using testing::ChildProcess;
using testing::Eventually;
using testing::WaitUntil;

// How long a test waits for an event before it fails: a bound against hangs, not a speed
// requirement (a loaded 2-core machine may be 20 times slower than a quiet one).
constexpr absl::Duration kPatience = absl::Seconds(120);

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
  RobotLoop loop(*client_, *base_, *scanner_, options);
  // Runs until the room's walls are mapped from enough answered scans, however long that takes.
  std::thread stopper([&] {
    Eventually(
        [&] {
          const RobotStatus s = loop.status();
          return s.scans_answered >= 8 && s.segments >= 3;
        },
        kPatience);
    stop_ = true;
  });
  auto status = loop.Run(stop_);
  stop_ = true;
  stopper.join();
  ASSERT_TRUE(status.ok()) << status.status() << "\n" << server_->Log();
  EXPECT_GE(status->scans_answered, 8u);
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
  // Stopped at the end: the fake reads the driver's last VEL 0 / RVEL 0 on its own thread, so it
  // may not have them yet when the loop returns.
  EXPECT_TRUE(Eventually(
      [&] { return robot_->last_velocities() == std::make_pair(0, 0); }, kPatience));
}

// `waymark --server SERVER ARGS...` of this build as a child process, its stdout and stderr in
// files of `dir`; `keyboard` gives it a stdin pipe (the teleop keys).
std::unique_ptr<ChildProcess> StartWaymark(const std::string& server,
                                           const std::vector<std::string>& args,
                                           const std::string& dir, bool keyboard = false) {
  ChildProcess::Options options;
  options.argv = {std::string(WAYMARK_BINARY_DIR) + "/bin/waymark", "--server", server};
  options.argv.insert(options.argv.end(), args.begin(), args.end());
  options.stdout_path = dir + "/out.txt";
  options.stderr_path = dir + "/err.txt";
  options.stdin_pipe = keyboard;
  auto child = ChildProcess::Start(options);
  EXPECT_TRUE(child.ok()) << child.status();
  return child.ok() ? *std::move(child) : nullptr;
}

// Waits until the child's stdout or stderr holds `text` (false if it exits first or never does).
bool WaitForOutput(ChildProcess& child, const std::string& text) {
  return WaitUntil(
      [&] {
        return child.Stdout().find(text) != std::string::npos ||
               child.Stderr().find(text) != std::string::npos || !child.Running();
      },
      kPatience) &&
         (child.Stdout().find(text) != std::string::npos ||
          child.Stderr().find(text) != std::string::npos);
}

// What the fake Pioneer was told: `mm_per_s` as a VEL at least `times` times.
bool SawVel(const FakeArcosPeer& robot, int mm_per_s, int times = 1) {
  return robot.WaitFor(
      [&](const std::vector<FakeArcosPeer::Command>& log) {
        int seen = 0;
        for (const auto& c : log) seen += c.name == "VEL" && c.arg == mm_per_s;
        return seen >= times;
      },
      kPatience);
}

// The session of `robot_id` on the server (scans processed, segments), once there is one.
std::optional<v1::Session> SessionOf(const std::string& server, const std::string& robot_id) {
  auto sessions = client::SlamClient(client::MakeChannel(server)).ListSessions(robot_id);
  if (!sessions.ok() || sessions->sessions_size() == 0) return std::nullopt;
  return sessions->sessions(0);
}

// Waits until the server has processed `scans` scans of `robot_id`'s session.
bool WaitForScans(const std::string& server, const std::string& robot_id, uint64_t scans) {
  return WaitUntil(
      [&] {
        const std::optional<v1::Session> session = SessionOf(server, robot_id);
        return session && session->scans_processed() >= scans;
      },
      kPatience);
}

// Ended with Ctrl-C once a status line shows the server answering: the time a slow machine needs
// to connect and answer is not a pass condition.
TEST_F(RobotLoopServerTest, CommandOnTheSerialFakes) {
  auto waymark = StartWaymark(server_->address(),
                              {"robot", "--base", "serial:" + robot_->device_path(), "--laser",
                               "serial:" + laser_->device_path(), "--json"},
                              dir_);
  ASSERT_NE(waymark, nullptr);
  EXPECT_TRUE(WaitForOutput(*waymark, "server=ok")) << waymark->Stderr();
  ASSERT_EQ(waymark->Stop(SIGINT), 0) << waymark->Stderr() << waymark->Stdout();
  const nlohmann::json summary = nlohmann::json::parse(waymark->Stdout());
  EXPECT_EQ(summary["mode"], "passive");
  EXPECT_GE(summary["scans_answered"].get<int>(), 1);
  EXPECT_THAT(summary["devices"].get<std::string>(), HasSubstr("181 beams"));
  EXPECT_EQ(summary["safety_stops"]["shutdown"].get<int>(), 1);
  // The drivers said goodbye: the laser stopped streaming, the robot connection was closed.
  EXPECT_TRUE(Eventually([&] { return !robot_->is_open(); }, kPatience));
  EXPECT_FALSE(robot_->ever_moved());
}

// Active exploration in the simulator, ended with Ctrl-C once the server has answered ten scans:
// the robot has then driven nine suggestions, each for its (simulated) duration (the first five
// or so turn it round: the nearest unseen space at the start is behind it). The simulator
// runs at 4x, not faster: it follows the wall clock, so a loop held up by a busy machine lets
// the robot drive on for 4 times as long, and at 10x that could end at a wall.
TEST_F(RobotLoopServerTest, CommandDrivesTheSimulatorThroughTheRealServerWithoutCollisions) {
  auto waymark = StartWaymark(server_->address(),
                              {"robot", "--base", "sim:office", "--laser", "sim", "--mode",
                               "active", "--sim-speed", "4", "--robot-id", "explorer", "--json"},
                              dir_);
  ASSERT_NE(waymark, nullptr);
  EXPECT_TRUE(WaitForScans(server_->address(), "explorer", 10)) << waymark->Stderr();
  ASSERT_EQ(waymark->Stop(SIGINT), 0) << waymark->Stderr() << waymark->Stdout();
  const nlohmann::json summary = nlohmann::json::parse(waymark->Stdout());
  EXPECT_GE(summary["suggestions_driven"].get<int>(), 9);
  EXPECT_GT(summary["sim"]["distance_m"].get<double>(), 0.3);
  EXPECT_EQ(summary["sim"]["collisions"].get<int>(), 0);
  EXPECT_EQ(summary["safety_stops"]["server stream broken"].get<int>(), 0);
  EXPECT_GE(summary["segments"].get<int>(), 5);
}

// The goal layer ends exploration of a small closed room after a few scans (the laser sees all of
// it from the start; the robot turns to look at what the first scan left open): the robot is
// stopped, the session closed, and the command exits by itself with success.
TEST_F(RobotLoopServerTest, ActiveExplorationEndsAtDoneWithTheRobotStopped) {
  const std::string world = dir_ + "/room.world";
  std::ofstream(world) << "name room\nstart 1.5 1.25 0\n"
                          "wall 0 0 3 0\nwall 3 0 3 2.5\nwall 3 2.5 0 2.5\nwall 0 2.5 0 0\n";
  auto waymark = StartWaymark(server_->address(),
                              {"robot", "--base", "sim:" + world, "--laser", "sim", "--mode",
                               "active", "--sim-speed", "4", "--robot-id", "room", "--json"},
                              dir_);
  ASSERT_NE(waymark, nullptr);
  const std::optional<int> code = waymark->WaitFor(kPatience);
  if (!code) waymark->Stop(SIGINT);
  ASSERT_EQ(code, 0) << waymark->Stderr() << waymark->Stdout();
  EXPECT_THAT(waymark->Stderr(), HasSubstr("exploration done: "));
  EXPECT_THAT(waymark->Stderr(), HasSubstr(": robot stopped"));
  const nlohmann::json summary = nlohmann::json::parse(waymark->Stdout());
  EXPECT_EQ(summary["exploration_state"], "done");
  EXPECT_FALSE(summary["exploration_reason"].get<std::string>().empty());
  EXPECT_EQ(summary["sim"]["collisions"].get<int>(), 0);
  EXPECT_EQ(summary["safety_stops"]["server stream broken"].get<int>(), 0);
  const std::optional<v1::Session> session = SessionOf(server_->address(), "room");
  ASSERT_TRUE(session.has_value());
  EXPECT_EQ(session->state(), v1::Session::CLOSED);
  EXPECT_EQ(session->scans_processed(), summary["scans_answered"].get<uint64_t>());
}

// Ctrl-C once the robot has driven a suggestion (the server processed a second scan, which the
// go-stop protocol sends only after the first hold).
TEST_F(RobotLoopServerTest, CtrlCStopsTheRobotClosesTheSessionAndExitsCleanly) {
  auto waymark = StartWaymark(server_->address(),
                              {"robot", "--base", "sim:office", "--laser", "sim", "--mode",
                               "active", "--sim-speed", "10", "--robot-id", "ctrl-c", "--json"},
                              dir_);
  ASSERT_NE(waymark, nullptr);
  EXPECT_TRUE(WaitForScans(server_->address(), "ctrl-c", 2)) << waymark->Stderr();
  ASSERT_EQ(waymark->Stop(SIGINT), 0) << waymark->Stderr() << waymark->Stdout();
  const nlohmann::json summary = nlohmann::json::parse(waymark->Stdout());
  EXPECT_EQ(summary["safety_stops"]["shutdown"].get<int>(), 1);
  EXPECT_GE(summary["suggestions_driven"].get<int>(), 1);
  auto sessions = client::SlamClient(client::MakeChannel(server_->address())).ListSessions();
  ASSERT_TRUE(sessions.ok());
  ASSERT_EQ(sessions->sessions_size(), 1);
  EXPECT_EQ(sessions->sessions(0).state(), v1::Session::CLOSED);
}

// Teleop on the serial fakes: the test is the keyboard and checks what reached the robot. Two
// presses of w are 0.1 m/s (VEL 100); the key thread re-sends the target while it is held, so
// the robot sees it again and again; q quits, and the robot is told to stand.
TEST_F(RobotLoopServerTest, TeleopDrivesWithKeysAndQuitsOnQ) {
  auto waymark = StartWaymark(server_->address(),
                              {"robot", "--base", "serial:" + robot_->device_path(), "--laser",
                               "serial:" + laser_->device_path(), "--mode", "teleop", "--json"},
                              dir_, /*keyboard=*/true);
  ASSERT_NE(waymark, nullptr);
  ASSERT_TRUE(waymark->WriteStdin("ww").ok());
  EXPECT_TRUE(SawVel(*robot_, 100, /*times=*/3)) << waymark->Stderr();
  EXPECT_TRUE(Eventually([&] { return robot_->pose().x > 0; }, kPatience));  // it drove ahead
  ASSERT_TRUE(waymark->WriteStdin("q").ok());
  ASSERT_EQ(waymark->Wait(), 0) << waymark->Stderr() << waymark->Stdout();
  EXPECT_THAT(waymark->Stderr(), HasSubstr("teleop: w/s"));
  const nlohmann::json summary = nlohmann::json::parse(waymark->Stdout());
  EXPECT_EQ(summary["mode"], "teleop");
  // Told to stand at the end (read by the fake on its own thread, maybe after the exit).
  EXPECT_TRUE(Eventually(
      [&] { return robot_->last_velocities() == std::make_pair(0, 0); }, kPatience));
  EXPECT_TRUE(Eventually([&] { return !robot_->is_open(); }, kPatience));
}

// The keyboard goes away (end of input) while the robot drives: it is stopped at once, and the
// run goes on (streaming, standing) until it is ended.
TEST_F(RobotLoopServerTest, TeleopStopsWhenTheKeyboardGoesAway) {
  auto waymark = StartWaymark(server_->address(),
                              {"robot", "--base", "serial:" + robot_->device_path(), "--laser",
                               "serial:" + laser_->device_path(), "--mode", "teleop", "--json"},
                              dir_, /*keyboard=*/true);
  ASSERT_NE(waymark, nullptr);
  ASSERT_TRUE(waymark->WriteStdin("ww").ok());
  EXPECT_TRUE(SawVel(*robot_, 100)) << waymark->Stderr();
  waymark->CloseStdin();
  EXPECT_TRUE(WaitForOutput(*waymark, "no more keyboard input")) << waymark->Stderr();
  EXPECT_TRUE(Eventually(
      [&] { return robot_->last_velocities() == std::make_pair(0, 0); }, kPatience));
  EXPECT_TRUE(waymark->Running());  // stopped by the lost keyboard, not by the end of the run
  ASSERT_EQ(waymark->Stop(SIGINT), 0) << waymark->Stderr() << waymark->Stdout();
  EXPECT_EQ(nlohmann::json::parse(waymark->Stdout())["mode"], "teleop");
}

// Ended once a status line carries the recognized crossing.
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
  auto run = [&](const std::vector<std::string>& args) {
    auto child = StartWaymark(server_->address(), args, dir_);
    return child ? child->Wait() : -1;
  };
  ASSERT_EQ(run({"db", "create", "streets"}), 0);
  ASSERT_EQ(run({"enroll", "streets", (fs::path(dir_) / "enroll").string()}), 0);

  auto waymark = StartWaymark(
      server_->address(),
      {"robot", "--base", "sim:office", "--laser", "sim", "--sim-speed", "10", "--camera",
       (camera_dir / "frame%d.png").string(), "--crossings", "streets", "--recognize-every", "0.5"},
      dir_);
  ASSERT_NE(waymark, nullptr);
  EXPECT_TRUE(WaitForOutput(*waymark, "crossing=K3")) << waymark->Stdout() << waymark->Stderr();
  ASSERT_EQ(waymark->Stop(SIGINT), 0) << waymark->Stderr() << waymark->Stdout();
  EXPECT_THAT(waymark->Stdout(), HasSubstr("crossing: K3 (heading 90 deg"));
  EXPECT_THAT(waymark->Stdout(), HasSubstr("stopped: session"));

  auto unknown = StartWaymark(server_->address(),
                              {"robot", "--base", "sim:office", "--laser", "sim", "--camera",
                               (camera_dir / "frame%d.png").string(), "--crossings", "nowhere"},
                              dir_);
  ASSERT_NE(unknown, nullptr);
  EXPECT_NE(unknown->Wait(), 0);
  EXPECT_THAT(unknown->Stderr(), HasSubstr("crossing database 'nowhere' not found"));
}

}  // namespace
}  // namespace waymark::cli
