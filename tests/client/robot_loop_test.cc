// The robot loop (`waymark robot`) and its safety pieces against the fake SlamService: scripted
// devices to check each stop rule, the simulator in fast real time for the whole loop, a stream
// the fake breaks on purpose for the stop-reconnect-resume path.
#include "client/robot/robot_loop.h"

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <functional>
#include <mutex>
#include <opencv2/imgcodecs.hpp>
#include <optional>
#include <thread>

#include <unistd.h>

#include "client/devices/camera_source.h"
#include "client/sim/sim_realtime.h"
#include "client/sim/sim_world.h"
#include "client/common/command_context.h"  // exit codes
#include "client/common/steady_clock.h"
#include "client/lib/channel.h"
#include "client/robot/crossing_watch.h"
#include "client/robot/robot_setup.h"
#include "client/robot/safety_guard.h"
#include "client/robot/teleop_keys.h"
#include "tests/client/fake_crossing_service.h"
#include "tests/client/fake_slam_service.h"
#include "tests/client/test_util.h"

namespace waymark::cli {
namespace {

using ::testing::HasSubstr;
using ::testing::Not;
using waymark::testing::CliResult;
using waymark::testing::FakeSlamServer;
using waymark::testing::RunWaymark;

// Polls `condition` for up to `seconds`: a bound against hangs, generous because a loaded machine
// may need seconds for what a quiet one does in milliseconds.
template <typename F>
bool WaitFor(F condition, double seconds = 60) {
  const double end = adapters::SteadySeconds() + seconds;
  while (adapters::SteadySeconds() < end) {
    if (condition()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return condition();
}

// A base that records every command; stamps are the wall clock; bumped/stalled/failing on demand.
// Events a loop or watch reports from its own threads, collected for the test's thread.
class EventRecorder {
 public:
  std::function<void(const std::string&)> Callback() {
    return [this](const std::string& e) {
      std::lock_guard<std::mutex> lock(mutex_);
      events_.push_back(e);
    };
  }
  std::vector<std::string> events() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return events_;
  }
  // The last event containing `text`, or "" when none does.
  std::string Find(const std::string& text) const {
    std::lock_guard<std::mutex> lock(mutex_);
    for (auto it = events_.rbegin(); it != events_.rend(); ++it) {
      if (it->find(text) != std::string::npos) return *it;
    }
    return "";
  }

 private:
  mutable std::mutex mutex_;
  std::vector<std::string> events_;
};

class ScriptedBase : public adapters::MobileBase {
 public:
  struct Command {
    bool stop;
    double linear, angular;
  };
  absl::Status SetVelocity(double linear, double angular) override {
    std::lock_guard<std::mutex> lock(mutex_);
    commands_.push_back({false, linear, angular});
    return absl::OkStatus();
  }
  absl::Status Stop() override {
    std::lock_guard<std::mutex> lock(mutex_);
    commands_.push_back({true, 0, 0});
    return absl::OkStatus();
  }
  absl::StatusOr<adapters::BaseState> Read() override {
    std::lock_guard<std::mutex> lock(mutex_);
    if (failing_) return absl::UnavailableError("no SIP for 1 s");
    adapters::BaseState state;
    state.stamp = adapters::SteadySeconds();
    state.bumped = bumped_;
    state.stalled = stalled_;
    return state;
  }
  double max_linear() const override { return 0.5; }
  double max_angular() const override { return 1.0; }

  std::vector<Command> commands() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return commands_;
  }
  bool last_is_stop() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return !commands_.empty() && commands_.back().stop;
  }
  void set_bumped(bool b) {
    std::lock_guard<std::mutex> lock(mutex_);
    bumped_ = b;
  }
  void set_stalled(bool b) {
    std::lock_guard<std::mutex> lock(mutex_);
    stalled_ = b;
  }
  void set_failing(bool b) {
    std::lock_guard<std::mutex> lock(mutex_);
    failing_ = b;
  }

 private:
  mutable std::mutex mutex_;
  std::vector<Command> commands_;
  bool bumped_ = false, stalled_ = false, failing_ = false;
};

// A 181-beam laser delivering a scan every 20 ms (wall clock), or failing on demand.
class ScriptedLaser : public adapters::LaserScanner {
 public:
  adapters::LaserLayout layout() const override {
    adapters::LaserLayout l;
    l.angle_min = -M_PI / 2;
    l.angle_increment = M_PI / 180;
    l.beam_count = 181;
    l.no_return_range = 8.183;
    return l;
  }
  absl::StatusOr<adapters::LaserReading> Read() override {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    if (failing_.load()) return absl::UnavailableError("LMS200 on /dev/ttyUSB0 hung up");
    return adapters::LaserReading{adapters::SteadySeconds(), std::vector<float>(181, 3.0f)};
  }
  std::atomic<bool> failing_{false};
};

v1::SuggestedControl Forward(double duration = 0.3) {
  v1::SuggestedControl c;
  c.set_linear(0.1);
  c.set_duration(duration);
  c.set_behaviour(v1::SuggestedControl::OPTIMAL);
  return c;
}

// ---- SafetyGuard ------------------------------------------------------------------------------

TEST(SafetyGuardTest, ClampsToTheConfiguredAndTheBaseLimits) {
  ScriptedBase base;  // its own limits: 0.5 m/s, 1 rad/s
  SafetyGuard guard(base, {/*max_linear=*/2.0, /*max_angular=*/0.3});
  EXPECT_DOUBLE_EQ(guard.limits().max_linear, 0.5);
  EXPECT_DOUBLE_EQ(guard.limits().max_angular, 0.3);
  ASSERT_TRUE(guard.Drive(5.0, -4.0, 10).ok());
  ASSERT_FALSE(base.commands().empty());
  EXPECT_DOUBLE_EQ(base.commands().back().linear, 0.5);
  EXPECT_DOUBLE_EQ(base.commands().back().angular, -0.3);
}

TEST(SafetyGuardTest, WatchdogStopsACommandThatOutlivesItsValidity) {
  ScriptedBase base;
  SafetyGuard guard(base, {}, /*time_scale=*/1.0, /*grace=*/0.0);
  ASSERT_TRUE(guard.Drive(0.2, 0, /*valid_for=*/0.05).ok());
  EXPECT_TRUE(WaitFor([&] { return !guard.moving(); }));
  EXPECT_TRUE(base.last_is_stop());
  EXPECT_EQ(guard.stops(StopReason::kCommandExpired), 1u);
  // A renewed command keeps it going: no expiry while commands keep coming.
  ASSERT_TRUE(guard.Drive(0.2, 0, 10).ok());
  std::this_thread::sleep_for(std::chrono::milliseconds(100));
  EXPECT_TRUE(guard.moving());
  EXPECT_EQ(guard.stops(StopReason::kCommandExpired), 1u);
}

TEST(SafetyGuardTest, RefusesNonFiniteCommandsAndStops) {
  ScriptedBase base;
  SafetyGuard guard(base, {});
  ASSERT_TRUE(guard.Drive(0.2, 0, 10).ok());
  EXPECT_EQ(guard.Drive(std::nan(""), 0, 1).code(), absl::StatusCode::kInvalidArgument);
  EXPECT_FALSE(guard.moving());
  EXPECT_TRUE(base.last_is_stop());
  EXPECT_EQ(guard.Drive(0.1, INFINITY, 1).code(), absl::StatusCode::kInvalidArgument);
}

TEST(SafetyGuardTest, HaltCountsItsReasonAndStopsTheBaseOnDestruction) {
  ScriptedBase base;
  {
    SafetyGuard guard(base, {});
    ASSERT_TRUE(guard.Drive(0.2, 0.1, 10).ok());
    ASSERT_TRUE(guard.Halt(StopReason::kBumper).ok());
    EXPECT_EQ(guard.stops(StopReason::kBumper), 1u);
    EXPECT_FALSE(guard.moving());
    ASSERT_TRUE(guard.Drive(0.2, 0.1, 10).ok());
  }
  EXPECT_TRUE(base.last_is_stop());
}

// ---- Teleop keys ------------------------------------------------------------------------------

TEST(TeleopKeysTest, StepsClampsStopsAndQuits) {
  TeleopTarget t;
  const VelocityLimits limits{0.12, 0.25};
  EXPECT_EQ(ApplyTeleopKey('w', t, limits), TeleopAction::kDrive);
  EXPECT_DOUBLE_EQ(t.linear, 0.05);
  ApplyTeleopKey('W', t, limits);
  ApplyTeleopKey('w', t, limits);
  EXPECT_DOUBLE_EQ(t.linear, 0.12);  // clamped
  ApplyTeleopKey('a', t, limits);
  ApplyTeleopKey('a', t, limits);
  ApplyTeleopKey('a', t, limits);
  EXPECT_DOUBLE_EQ(t.angular, 0.25);
  ApplyTeleopKey('d', t, limits);
  EXPECT_NEAR(t.angular, 0.15, 1e-12);
  for (int i = 0; i < 10; ++i) ApplyTeleopKey('s', t, limits);
  EXPECT_DOUBLE_EQ(t.linear, -0.12);  // backwards, clamped too
  EXPECT_EQ(ApplyTeleopKey(' ', t, limits), TeleopAction::kStop);
  EXPECT_EQ(t.linear, 0);
  EXPECT_EQ(t.angular, 0);
  EXPECT_EQ(ApplyTeleopKey('c', t, limits), TeleopAction::kRecognize);
  EXPECT_EQ(ApplyTeleopKey('q', t, limits), TeleopAction::kQuit);
  EXPECT_EQ(ApplyTeleopKey('?', t, limits), TeleopAction::kNone);
}

// Issue 35: q quits in every mode; the driving keys do nothing outside teleop.
TEST(TeleopKeysTest, QuitAndRecognizeWorkInEveryModeDrivingOnlyInTeleop) {
  TeleopTarget t;
  const VelocityLimits limits{0.3, 0.5};
  for (bool teleop : {true, false}) {
    EXPECT_EQ(ApplyKey('q', teleop, t, limits), TeleopAction::kQuit) << teleop;
    EXPECT_EQ(ApplyKey('Q', teleop, t, limits), TeleopAction::kQuit) << teleop;
    EXPECT_EQ(ApplyKey('c', teleop, t, limits), TeleopAction::kRecognize) << teleop;
  }
  EXPECT_EQ(ApplyKey('w', /*teleop=*/false, t, limits), TeleopAction::kNone);
  EXPECT_EQ(ApplyKey(' ', /*teleop=*/false, t, limits), TeleopAction::kNone);
  EXPECT_EQ(t.linear, 0);
  EXPECT_EQ(ApplyKey('w', /*teleop=*/true, t, limits), TeleopAction::kDrive);
  EXPECT_DOUBLE_EQ(t.linear, 0.05);
  EXPECT_THAT(KeysHelp(false), HasSubstr("q quit"));
}

// The keyboard reader on a pipe, as `waymark robot` runs it on stdin.
class KeyPipe {
 public:
  KeyPipe() { EXPECT_EQ(pipe(fds_), 0); }
  ~KeyPipe() {
    CloseWriter();
    close(fds_[0]);
  }
  int reader() const { return fds_[0]; }
  void Write(const std::string& keys) {
    EXPECT_EQ(write(fds_[1], keys.data(), keys.size()), static_cast<ssize_t>(keys.size()));
  }
  void CloseWriter() {
    if (fds_[1] >= 0) close(fds_[1]);
    fds_[1] = -1;
  }

 private:
  int fds_[2] = {-1, -1};
};

TEST(KeyboardTest, QQuitsAnActiveRunAndTheDrivingKeysAreIgnored) {
  KeyPipe keys;
  std::atomic<bool> stop{false};
  int quits = 0, recognitions = 0;
  EventRecorder said;
  KeyboardHooks hooks;  // no drive hook: active (or passive) mode
  hooks.quit = [&] { ++quits; };
  hooks.recognize = [&] { ++recognitions; };
  hooks.say = said.Callback();
  keys.Write("wadcxq");
  std::thread reader([&] { ReadKeys(keys.reader(), stop, {0.3, 0.5}, hooks, 10); });
  reader.join();  // q ends the reading by itself
  EXPECT_EQ(quits, 1);
  EXPECT_EQ(recognitions, 1);
  EXPECT_THAT(said.Find("q:"), HasSubstr("stopping"));
}

TEST(KeyboardTest, TheEndOfInputStopsATeleopRobotButNotAnActiveRun) {
  {
    KeyPipe keys;
    std::atomic<bool> stop{false};
    int quits = 0;
    EventRecorder said;
    KeyboardHooks hooks;
    hooks.quit = [&] { ++quits; };
    hooks.say = said.Callback();
    keys.CloseWriter();
    ReadKeys(keys.reader(), stop, {0.3, 0.5}, hooks, 10);
    EXPECT_EQ(quits, 0);  // the run goes on (stdin from /dev/null, say)
    EXPECT_TRUE(said.events().empty());
  }
  {
    KeyPipe keys;
    std::atomic<bool> stop{false};
    std::vector<std::pair<double, double>> drives;
    EventRecorder said;
    KeyboardHooks hooks;
    hooks.quit = [] {};
    hooks.drive = [&](double linear, double angular) {
      drives.emplace_back(linear, angular);
      return absl::OkStatus();
    };
    hooks.base_stopped = [] { return false; };
    hooks.say = said.Callback();
    keys.Write("w");
    keys.CloseWriter();
    ReadKeys(keys.reader(), stop, {0.3, 0.5}, hooks, 10);
    ASSERT_GE(drives.size(), 2u);
    EXPECT_DOUBLE_EQ(drives.front().first, 0.05);
    EXPECT_EQ(drives.back(), std::make_pair(0.0, 0.0));
    EXPECT_THAT(said.Find("no more keyboard input"), HasSubstr("stopping"));
  }
}

// ---- Device specs -----------------------------------------------------------------------------

TEST(RobotSetupTest, ParsesDeviceSpecsAndRefusesMixtures) {
  auto serial = ParseDeviceSpec("serial:/dev/ttyS0", "--base");
  ASSERT_TRUE(serial.ok());
  EXPECT_EQ(serial->kind, DeviceSpec::Kind::kSerial);
  EXPECT_EQ(serial->argument, "/dev/ttyS0");
  auto sim = ParseDeviceSpec("sim:office", "--base");
  ASSERT_TRUE(sim.ok());
  EXPECT_EQ(sim->kind, DeviceSpec::Kind::kSim);
  EXPECT_EQ(sim->argument, "office");
  auto bad = ParseDeviceSpec("/dev/ttyS0", "--base");
  ASSERT_FALSE(bad.ok());
  EXPECT_THAT(std::string(bad.status().message()), HasSubstr("serial:DEVICE"));
  EXPECT_FALSE(ParseDeviceSpec("serial:", "--laser").ok());

  RobotSetupOptions mixed;
  mixed.base = "sim:corridor";
  mixed.laser = "serial:/dev/ttyUSB0";
  EXPECT_EQ(OpenRobotDevices(mixed).status().code(), absl::StatusCode::kInvalidArgument);
  RobotSetupOptions no_world;
  no_world.base = "sim";
  EXPECT_EQ(OpenRobotDevices(no_world).status().code(), absl::StatusCode::kInvalidArgument);
  RobotSetupOptions unknown_world;
  unknown_world.base = "sim:atlantis";
  EXPECT_FALSE(OpenRobotDevices(unknown_world).ok());
  RobotSetupOptions missing_port;
  missing_port.base = "serial:/dev/ttyWAYMARK_none";
  missing_port.laser = "serial:/dev/ttyWAYMARK_none2";
  auto opened = OpenRobotDevices(missing_port);
  ASSERT_FALSE(opened.ok());
  EXPECT_THAT(std::string(opened.status().message()), HasSubstr("/dev/ttyWAYMARK_none2"));
}

// ---- The loop ---------------------------------------------------------------------------------

class RobotLoopTest : public ::testing::Test {
 protected:
  client::SlamClient& Client() {
    if (!client_)
      client_ = std::make_unique<client::SlamClient>(client::MakeChannel(server_.address()));
    return *client_;
  }

  // The built-in office world, `speed` times faster than real time.
  static std::unique_ptr<adapters::RealTimeSimulation> Office(double speed) {
    auto world = adapters::LoadWorld("office");
    EXPECT_TRUE(world.ok()) << world.status();
    adapters::RealTimeSimOptions options;
    options.speed = speed;
    return std::make_unique<adapters::RealTimeSimulation>(*std::move(world), options);
  }

  // Active mode against the fake answering forward suggestions until it ends exploration with
  // `state` (and `reason`) at scan `at`.
  RobotLoopOptions ActiveUntil(int at, v1::ExplorationProgress::State state,
                               const std::string& reason) {
    server_.service().set_suggestion(Forward(/*duration=*/0.3));
    server_.service().set_exploration_end(at, state, reason);
    RobotLoopOptions options;
    options.mode = DriveMode::kActive;
    return options;
  }

  FakeSlamServer server_;
  std::unique_ptr<client::SlamClient> client_;
  std::atomic<bool> stop_{false};
};

TEST_F(RobotLoopTest, PassiveStreamsEveryScanWithIncreasingStampsAndClosesTheSession) {
  auto office = Office(/*speed=*/20);
  adapters::RealTimeSimulation& sim = *office;
  RobotLoopOptions options;
  options.robot_id = "r1";
  options.time_scale = 20;
  RobotLoop loop(Client(), sim.base(), sim.laser(), options);
  // Until five scans are answered, however long a loaded machine takes for them (at 20x the loop
  // has 5 ms of wall time per scan, and a slow one skips scans).
  std::thread stopper([&] {
    WaitFor([&] { return loop.status().scans_answered >= 5; });
    stop_ = true;
  });
  auto status = loop.Run(stop_);
  stop_ = true;
  stopper.join();
  ASSERT_TRUE(status.ok()) << status.status();
  EXPECT_GE(status->scans_answered, 5u);
  // Never faster than the laser's 10 Hz, however long the run took.
  EXPECT_LE(status->scans_sent, status->device_time / 0.1 + 2);
  EXPECT_EQ(status->scans_rejected, 0u);
  EXPECT_EQ(server_.service().last_create().robot_id(), "r1");
  EXPECT_EQ(server_.service().last_create().laser().laser().beam_count(), 181u);
  EXPECT_EQ(server_.service().last_create().laser().exploration().mode(),
            v1::ExplorationConfig::PASSIVE);
  const auto scans = server_.service().scan_stamps();
  for (size_t i = 1; i < scans.size(); ++i) EXPECT_GT(scans[i], scans[i - 1]);
  EXPECT_DOUBLE_EQ(sim.distance_travelled(), 0);  // passive: never moves
  auto sessions = Client().ListSessions();
  ASSERT_TRUE(sessions.ok());
  ASSERT_EQ(sessions->sessions_size(), 1);
  EXPECT_EQ(sessions->sessions(0).state(), v1::Session::CLOSED);
}

TEST_F(RobotLoopTest, ActiveDrivesEachSuggestionForItsDurationThenStops) {
  server_.service().set_suggestion(Forward(/*duration=*/1.0));
  // Each answer takes at least 50 ms: a whole simulated second at 20x. The hold starts when the
  // suggestion is driven, so the wait must not eat into it.
  server_.service().set_scan_delay(absl::Milliseconds(50));
  auto office = Office(/*speed=*/20);
  adapters::RealTimeSimulation& sim = *office;
  RobotLoopOptions options;
  options.mode = DriveMode::kActive;
  options.time_scale = 20;
  RobotLoop loop(Client(), sim.base(), sim.laser(), options);
  // Until the third suggestion: the first two holds then ran to their end (a hold is measured in
  // simulated time, so a slow machine does not shorten it).
  std::thread stopper([&] {
    WaitFor([&] { return loop.status().suggestions_driven >= 3; });
    stop_ = true;
  });
  auto status = loop.Run(stop_);
  stop_ = true;
  stopper.join();
  ASSERT_TRUE(status.ok()) << status.status();
  EXPECT_EQ(server_.service().last_create().laser().exploration().mode(),
            v1::ExplorationConfig::ACTIVE);
  EXPECT_GE(status->suggestions_driven, 3u);
  // Two full 1 s holds at 0.1 m/s (the simulated Pioneer accelerates at a finite rate).
  EXPECT_GT(sim.distance_travelled(), 0.15);
  // No upper bound on the distance, and no check that the watchdog never cut a hold: the
  // simulator follows the wall clock, so a loop held up by a busy machine lets the robot roll on
  // 20 times as long (the watchdog's grace is 0.2 s of wall-clock time).
  auto state = sim.base().Read();
  ASSERT_TRUE(state.ok());
  EXPECT_EQ(state->linear, 0);  // stopped at the end
}

TEST_F(RobotLoopTest, ActiveModeOnAPassiveSessionIsAnErrorAndTheRobotStaysStill) {
  ScriptedBase base;
  ScriptedLaser laser;
  RobotLoopOptions options;
  options.mode = DriveMode::kActive;
  RobotLoop loop(Client(), base, laser, options);
  auto status = loop.Run(stop_);
  ASSERT_FALSE(status.ok());
  EXPECT_EQ(status.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(std::string(status.status().message()), HasSubstr("suggests no controls"));
  for (const auto& c : base.commands()) EXPECT_TRUE(c.stop);
}

TEST_F(RobotLoopTest, ABrokenStreamStopsTheBaseThenTheLoopReconnectsToTheSameSession) {
  server_.service().set_suggestion(Forward(/*duration=*/0.3));
  server_.service().set_break_streams_after(3);
  ScriptedBase base;
  ScriptedLaser laser;
  RobotLoopOptions options;
  options.mode = DriveMode::kActive;
  options.reconnect_initial = absl::Milliseconds(50);
  options.reconnect_max = absl::Milliseconds(200);
  options.answer_timeout = absl::Seconds(2);
  RobotLoop loop(Client(), base, laser, options);
  std::vector<bool> stopped_at_break;
  loop.set_event_callback([&](const std::string& e) {
    if (e.find("stream broken") != std::string::npos)
      stopped_at_break.push_back(base.last_is_stop());
  });
  std::thread stopper([&] {
    WaitFor([&] { return server_.service().streams_opened() >= 3; }, 20);
    stop_ = true;
  });
  auto status = loop.Run(stop_);
  stopper.join();
  ASSERT_TRUE(status.ok()) << status.status();
  ASSERT_GE(stopped_at_break.size(), 2u);
  for (bool stopped : stopped_at_break) EXPECT_TRUE(stopped);
  EXPECT_GE(status->stops[static_cast<int>(StopReason::kStreamBroken)], 2u);
  EXPECT_GE(status->reconnects, 2u);
  EXPECT_GE(server_.service().streams_opened(), 3);
  // One session throughout: the reconnects resumed it.
  auto sessions = Client().ListSessions();
  ASSERT_TRUE(sessions.ok());
  EXPECT_EQ(sessions->sessions_size(), 1);
  EXPECT_GE(status->scans_answered, 6u);
  EXPECT_TRUE(base.last_is_stop());
}

// Issue 15: after a server lost its shutdown checkpoint, the robot's session "resumed from its
// checkpoint (0 scans, 0 poses)" and went on from (0, 0) without a word.
TEST_F(RobotLoopTest, ASessionThatResumedFromAnOlderCheckpointIsWarnedAbout) {
  server_.service().set_break_streams_after(4);
  server_.service().set_rollback_on_break(1);  // the "server" lost scans 2..4 with the break
  ScriptedBase base;
  ScriptedLaser laser;
  RobotLoopOptions options;
  options.reconnect_initial = absl::Milliseconds(50);
  options.reconnect_max = absl::Milliseconds(200);
  RobotLoop loop(Client(), base, laser, options);
  EventRecorder events;
  loop.set_event_callback(events.Callback());
  std::thread stopper([&] {
    WaitFor([&] { return !events.Find("resumed from").empty(); }, 60);
    stop_ = true;
  });
  auto status = loop.Run(stop_);
  stopper.join();
  ASSERT_TRUE(status.ok()) << status.status();
  const std::string warning = events.Find("resumed from");
  EXPECT_THAT(warning, HasSubstr("warning: session s1 resumed from a checkpoint 3 scans / "));
  EXPECT_THAT(warning, HasSubstr("behind this robot's stream: the map and the pose restart"));
}

TEST_F(RobotLoopTest, AStreamReopenedOnAnIntactSessionIsNotWarnedAbout) {
  server_.service().set_break_streams_after(4);  // a network break: the session keeps everything
  ScriptedBase base;
  ScriptedLaser laser;
  RobotLoopOptions options;
  options.reconnect_initial = absl::Milliseconds(50);
  RobotLoop loop(Client(), base, laser, options);
  EventRecorder events;
  loop.set_event_callback(events.Callback());
  std::thread stopper([&] {
    WaitFor([&] { return server_.service().streams_opened() >= 3; }, 60);
    stop_ = true;
  });
  auto status = loop.Run(stop_);
  stopper.join();
  ASSERT_TRUE(status.ok()) << status.status();
  EXPECT_EQ(events.Find("warning"), "");
}

TEST_F(RobotLoopTest, BumperAndStallStopTheBase) {
  server_.service().set_suggestion(Forward(/*duration=*/5.0));
  ScriptedBase base;
  ScriptedLaser laser;
  RobotLoopOptions options;
  options.mode = DriveMode::kActive;
  RobotLoop loop(Client(), base, laser, options);
  std::thread script([&] {
    WaitFor([&] {
      auto c = base.commands();
      return !c.empty() && !c.back().stop;
    });
    base.set_bumped(true);
    WaitFor([&] { return loop.status().stops[static_cast<int>(StopReason::kBumper)] > 0; });
    base.set_bumped(false);
    base.set_stalled(true);
    WaitFor([&] { return loop.status().stops[static_cast<int>(StopReason::kStall)] > 0; });
    stop_ = true;
  });
  auto status = loop.Run(stop_);
  script.join();
  ASSERT_TRUE(status.ok()) << status.status();
  EXPECT_GE(status->stops[static_cast<int>(StopReason::kBumper)], 1u);
  EXPECT_GE(status->stops[static_cast<int>(StopReason::kStall)], 1u);
  // Stopped well before the 5 s holds ran out: the bumper cut them, not the watchdog.
  EXPECT_EQ(status->stops[static_cast<int>(StopReason::kCommandExpired)], 0u);
  EXPECT_TRUE(base.last_is_stop());
}

TEST_F(RobotLoopTest, ALaserThatKeepsFailingEndsTheRunWithTheRobotStopped) {
  ScriptedBase base;
  ScriptedLaser laser;
  laser.failing_ = true;
  RobotLoopOptions options;
  options.device_grace = absl::Milliseconds(300);
  RobotLoop loop(Client(), base, laser, options);
  auto status = loop.Run(stop_);
  ASSERT_FALSE(status.ok());
  EXPECT_EQ(status.status().code(), absl::StatusCode::kUnavailable);
  EXPECT_THAT(std::string(status.status().message()), HasSubstr("laser stopped reporting"));
  EXPECT_THAT(std::string(status.status().message()), HasSubstr("/dev/ttyUSB0"));
  EXPECT_TRUE(base.last_is_stop());
}

TEST_F(RobotLoopTest, ALaserBackWithinTheGraceIsSurvived) {
  ScriptedBase base;
  ScriptedLaser laser;
  RobotLoopOptions options;
  options.device_grace = absl::Seconds(30);
  RobotLoop loop(Client(), base, laser, options);
  std::thread script([&] {
    WaitFor([&] { return loop.status().scans_answered >= 3; });
    laser.failing_ = true;  // cable out
    WaitFor([&] { return !loop.status().laser_error.empty(); });
    laser.failing_ = false;  // cable back
    const uint64_t before = loop.status().scans_answered;
    WaitFor([&] { return loop.status().scans_answered >= before + 3; });
    stop_ = true;
  });
  auto status = loop.Run(stop_);
  script.join();
  ASSERT_TRUE(status.ok()) << status.status();
  EXPECT_GE(status->stops[static_cast<int>(StopReason::kDeviceError)], 1u);
  EXPECT_TRUE(status->laser_error.empty());
  EXPECT_GE(status->scans_answered, 6u);
}

TEST_F(RobotLoopTest, ResumesAnOpenSessionInsteadOfCreatingOne) {
  ScriptedBase base;
  ScriptedLaser laser;
  v1::CreateSessionRequest create;
  create.set_robot_id("r2");
  create.mutable_laser()->mutable_laser()->set_beam_count(181);
  auto session = Client().CreateSession(create);
  ASSERT_TRUE(session.ok());
  RobotLoopOptions options;
  options.resume_session_id = session->session_id();
  options.close_session = false;
  options.duration_s = 0.3;
  RobotLoop loop(Client(), base, laser, options);
  auto status = loop.Run(stop_);
  ASSERT_TRUE(status.ok()) << status.status();
  EXPECT_EQ(status->session_id, session->session_id());
  auto sessions = Client().ListSessions();
  ASSERT_TRUE(sessions.ok());
  EXPECT_EQ(sessions->sessions_size(), 1);
  EXPECT_GT(status->scans_answered, 0u);
}

// ---- The end of exploration (goal layer: DONE, STUCK) ------------------------------------------

// Runs `loop` on the test's thread until it ends by itself; a loop that does not within the
// patience is stopped (the test then fails): a bound against a hang, not a speed requirement.
absl::StatusOr<RobotStatus> RunUntilItEnds(RobotLoop& loop, std::atomic<bool>& stop,
                                           bool& ended_by_itself) {
  std::atomic<bool> returned{false};
  std::thread patience([&] {
    if (!WaitFor([&] { return returned.load(); }, 120)) stop = true;
  });
  auto status = loop.Run(stop);
  ended_by_itself = !stop.load();
  returned = true;
  patience.join();
  return status;
}

// The base's commands after the event containing `text` (an event comes from the loop's thread,
// so the commands up to it were all sent before it).
class CommandsAfterEvent {
 public:
  CommandsAfterEvent(RobotLoop& loop, ScriptedBase& base, std::string text) : base_(base) {
    loop.set_event_callback([this, text](const std::string& e) {
      if (e.find(text) == std::string::npos) return;
      std::lock_guard<std::mutex> lock(mutex_);
      event_ = e;
      at_ = base_.commands().size();
    });
  }
  std::string event() const {
    std::lock_guard<std::mutex> lock(mutex_);
    return event_;
  }
  // Commands up to the event (the last one is the stop that went with it), and after it.
  std::vector<ScriptedBase::Command> before() const {
    const auto all = base_.commands();
    std::lock_guard<std::mutex> lock(mutex_);
    return {all.begin(), all.begin() + std::min(at_, all.size())};
  }
  std::vector<ScriptedBase::Command> after() const {
    const auto all = base_.commands();
    std::lock_guard<std::mutex> lock(mutex_);
    return {all.begin() + std::min(at_, all.size()), all.end()};
  }

 private:
  ScriptedBase& base_;
  mutable std::mutex mutex_;
  std::string event_;
  size_t at_ = 0;
};

int Drives(const std::vector<ScriptedBase::Command>& commands) {
  return static_cast<int>(std::count_if(commands.begin(), commands.end(),
                                        [](const ScriptedBase::Command& c) { return !c.stop; }));
}

TEST_F(RobotLoopTest, DoneStopsTheRobotEndsTheRunAndClosesTheSession) {
  RobotLoopOptions options =
      ActiveUntil(4, v1::ExplorationProgress::DONE, "every frontier explored");
  ScriptedBase base;
  ScriptedLaser laser;
  options.status_period = absl::ZeroDuration();  // a status after every step
  RobotLoop loop(Client(), base, laser, options);
  CommandsAfterEvent commands(loop, base, "exploration done");
  std::vector<RobotStatus> statuses;  // the status callback runs on the loop's thread
  loop.set_status_callback([&](const RobotStatus& s) { statuses.push_back(s); });
  bool ended_by_itself = false;
  auto status = RunUntilItEnds(loop, stop_, ended_by_itself);
  ASSERT_TRUE(status.ok()) << status.status();
  EXPECT_TRUE(ended_by_itself);
  EXPECT_EQ(status->exploration_end.state(), v1::ExplorationProgress::DONE);
  EXPECT_EQ(status->exploration_end.reason(), "every frontier explored");
  EXPECT_EQ(commands.event(), "exploration done: every frontier explored: robot stopped");
  // Three suggestions driven, then the fourth scan's DONE: no scan, no drive after it.
  EXPECT_EQ(status->suggestions_driven, 3u);
  EXPECT_EQ(server_.service().scans_received(), 4);
  const auto before = commands.before();
  EXPECT_EQ(Drives(before), 3);
  ASSERT_FALSE(before.empty());
  EXPECT_TRUE(before.back().stop);  // the stop that DONE sent
  const auto after = commands.after();
  EXPECT_EQ(Drives(after), 0);
  EXPECT_TRUE(base.last_is_stop());
  // The status showed the progress on the way (the fake: half the boundary open, 2 targets).
  const auto exploring = std::find_if(statuses.begin(), statuses.end(), [](const RobotStatus& s) {
    return s.exploration.state() == v1::ExplorationProgress::EXPLORING;
  });
  ASSERT_NE(exploring, statuses.end());
  EXPECT_DOUBLE_EQ(exploring->exploration.open_boundary(), 0.5);
  EXPECT_EQ(exploring->exploration.targets_left(), 2u);
  EXPECT_EQ(status->exploration.state(), v1::ExplorationProgress::DONE);
  auto sessions = Client().ListSessions();
  ASSERT_TRUE(sessions.ok());
  ASSERT_EQ(sessions->sessions_size(), 1);
  EXPECT_EQ(sessions->sessions(0).state(), v1::Session::CLOSED);
}

TEST_F(RobotLoopTest, StuckStopsTheRobotAndEndsTheRunToo) {
  RobotLoopOptions options =
      ActiveUntil(2, v1::ExplorationProgress::STUCK, "no collision-free control");
  ScriptedBase base;
  ScriptedLaser laser;
  RobotLoop loop(Client(), base, laser, options);
  CommandsAfterEvent commands(loop, base, "exploration stuck");
  bool ended_by_itself = false;
  auto status = RunUntilItEnds(loop, stop_, ended_by_itself);
  ASSERT_TRUE(status.ok()) << status.status();
  EXPECT_TRUE(ended_by_itself);
  EXPECT_EQ(status->exploration_end.state(), v1::ExplorationProgress::STUCK);
  EXPECT_EQ(commands.event(), "exploration stuck: no collision-free control: robot stopped");
  EXPECT_EQ(server_.service().scans_received(), 2);
  EXPECT_EQ(Drives(commands.before()), 1);
  EXPECT_EQ(Drives(commands.after()), 0);
}

// Passive and teleop runs stream into sessions that may report progress too: it never ends them.
TEST_F(RobotLoopTest, OnlyActiveModeEndsAtDone) {
  server_.service().set_exploration_end(1, v1::ExplorationProgress::DONE, "nothing left");
  ScriptedBase base;
  ScriptedLaser laser;
  RobotLoopOptions options;
  RobotLoop loop(Client(), base, laser, options);
  std::thread stopper([&] {
    WaitFor([&] { return loop.status().scans_answered >= 3; });
    stop_ = true;
  });
  auto status = loop.Run(stop_);
  stopper.join();
  ASSERT_TRUE(status.ok()) << status.status();
  EXPECT_GE(status->scans_answered, 3u);
  EXPECT_EQ(status->exploration.state(), v1::ExplorationProgress::DONE);
  EXPECT_EQ(status->exploration_end.state(), v1::ExplorationProgress::STATE_UNSPECIFIED);
}

TEST_F(RobotLoopTest, KeepRunningStandsStreamingWithTheSessionOpenUntilStopped) {
  RobotLoopOptions options =
      ActiveUntil(3, v1::ExplorationProgress::DONE, "every frontier explored");
  ScriptedBase base;
  ScriptedLaser laser;
  options.keep_running = true;
  RobotLoop loop(Client(), base, laser, options);
  CommandsAfterEvent commands(loop, base, "exploration done");
  std::optional<v1::Session::State> state_while_standing;
  std::thread stopper([&] {
    // Scans go on after DONE (the third): the loop streams while the robot stands.
    WaitFor([&] { return server_.service().scans_received() >= 6; });
    auto sessions = Client().ListSessions();
    if (sessions.ok() && sessions->sessions_size() == 1) {
      state_while_standing = sessions->sessions(0).state();
    }
    stop_ = true;
  });
  auto status = loop.Run(stop_);
  stopper.join();
  ASSERT_TRUE(status.ok()) << status.status();
  EXPECT_THAT(commands.event(), HasSubstr("robot stopped; it stands, streaming"));
  EXPECT_EQ(status->exploration_end.state(), v1::ExplorationProgress::DONE);
  EXPECT_GE(server_.service().scans_received(), 6);
  EXPECT_GE(status->scans_answered, 6u);
  EXPECT_EQ(status->suggestions_driven, 2u);
  EXPECT_EQ(Drives(commands.before()), 2);
  EXPECT_EQ(Drives(commands.after()), 0);
  EXPECT_EQ(state_while_standing, v1::Session::OPEN);
  auto sessions = Client().ListSessions();
  ASSERT_TRUE(sessions.ok());
  ASSERT_EQ(sessions->sessions_size(), 1);
  EXPECT_EQ(sessions->sessions(0).state(), v1::Session::CLOSED);  // closed when it was stopped
}

// ---- Crossing recognition from the camera ------------------------------------------------------

TEST(CrossingWatchTest, ReportsFailedCallsAndAnExhaustedCameraAndGoesOn) {
  waymark::testing::FakeServer server;  // no database "nowhere" on it
  waymark::testing::ScopedTempDir dir;
  cv::imwrite((dir.path() / "frame0.png").string(),
              cv::Mat(240, 320, CV_8UC3, cv::Scalar(0, 90, 200)));
  auto camera = client::CameraSource::Open((dir.path() / "frame%d.png").string());
  ASSERT_TRUE(camera.ok()) << camera.status();
  client::CrossingClient client(client::MakeChannel(server.address()));
  EventRecorder recorder;
  CrossingWatch watch(client, *std::move(camera), "nowhere", /*period_s=*/0,
                      recorder.Callback());
  EXPECT_EQ(watch.last().attempts, 0u);  // period 0: only on request
  watch.Request();
  ASSERT_TRUE(WaitFor([&] { return watch.last().attempts == 1; }));
  EXPECT_THAT(watch.last().summary, HasSubstr("recognition failed: NOT_FOUND"));
  watch.Request();  // the one-frame sequence is used up
  ASSERT_TRUE(WaitFor([&] { return watch.last().attempts == 2; }));
  EXPECT_THAT(watch.last().summary, HasSubstr("camera: OUT_OF_RANGE"));
  EXPECT_EQ(watch.last().failures, 2u);
  EXPECT_FALSE(watch.last().recognized);
  const std::vector<std::string> events = recorder.events();
  ASSERT_EQ(events.size(), 2u);
  EXPECT_THAT(events[1], HasSubstr("crossing: camera: OUT_OF_RANGE"));
}

TEST(CrossingWatchTest, DescribesAnswers) {
  v1::RecognizeResponse yes;
  yes.set_recognized(true);
  yes.set_crossing("K3");
  yes.set_heading_deg(91.6);
  yes.set_decision(0.812);
  EXPECT_EQ(DescribeRecognition(yes), "K3 (heading 92 deg, Des 0.81)");
  v1::RecognizeResponse no;
  no.set_reason("too few matches");
  EXPECT_EQ(DescribeRecognition(no), "not recognized (too few matches)");
}

// ---- The command ------------------------------------------------------------------------------

TEST_F(RobotLoopTest, CommandRunsTheSimulatorAndPrintsStatusLinesAndASummary) {
  CliResult r = RunWaymark(server_.address(),
                           {"robot", "--base", "sim:office", "--laser", "sim", "--duration", "15",
                            "--sim-speed", "10", "--robot-id", "cli-robot"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("simulated Pioneer with LMS200 in world 'office'"));
  // A status line at the start and one every wall-clock second; whether one falls after the first
  // answer (server=ok) depends on the machine's speed, so only the field is checked here (the
  // serial-fakes test in tests/robot waits for server=ok).
  EXPECT_THAT(r.out, HasSubstr("pose=("));
  EXPECT_THAT(r.out, HasSubstr(" server="));
  EXPECT_THAT(r.out, HasSubstr("stopped: session"));
  EXPECT_EQ(server_.service().last_create().robot_id(), "cli-robot");
}

// --explore picks the session's exploration mode behind --mode active (ACTIVE by default).
TEST_F(RobotLoopTest, CommandExploreFlagPicksTheSessionsExplorationMode) {
  server_.service().set_suggestion(Forward(/*duration=*/0.3));
  server_.service().set_exploration_end(2, v1::ExplorationProgress::DONE, "explored");
  for (const auto& [flag, mode] :
       std::vector<std::pair<std::string, v1::ExplorationConfig::Mode>>{
           {"", v1::ExplorationConfig::ACTIVE},
           {"frontier", v1::ExplorationConfig::FRONTIER},
           {"wander", v1::ExplorationConfig::WANDER}}) {
    std::vector<std::string> args = {"robot", "--base", "sim:office", "--laser", "sim",
                                     "--mode", "active", "--sim-speed", "10"};
    if (!flag.empty()) {
      args.push_back("--explore");
      args.push_back(flag);
    }
    CliResult r = RunWaymark(server_.address(), args);
    ASSERT_EQ(r.code, 0) << flag << ": " << r.err;
    EXPECT_EQ(server_.service().last_create().laser().exploration().mode(), mode) << flag;
  }
  CliResult bad = RunWaymark(server_.address(), {"robot", "--base", "sim:office", "--laser", "sim",
                                                 "--mode", "active", "--explore", "spiral"});
  EXPECT_NE(bad.code, 0);
  EXPECT_THAT(bad.err, HasSubstr("--explore"));
}

// DONE ends `waymark robot --mode active` with exit code 0 and says so; the status lines carry
// the progress. Each answer takes at least 150 ms, so twelve of them outlast the one second
// between status lines however fast the machine is: one falls after the first answer.
TEST_F(RobotLoopTest, CommandEndsAtDoneWithSuccessAndTheStateInTheSummary) {
  server_.service().set_suggestion(Forward(/*duration=*/0.3));
  server_.service().set_scan_delay(absl::Milliseconds(150));
  server_.service().set_exploration_end(12, v1::ExplorationProgress::DONE,
                                        "every frontier explored");
  CliResult r = RunWaymark(server_.address(), {"robot", "--base", "sim:office", "--laser", "sim",
                                               "--mode", "active", "--sim-speed", "10", "--json"});
  ASSERT_EQ(r.code, 0) << r.err;
  const nlohmann::json summary = r.Json();
  EXPECT_EQ(summary["exploration_state"], "done");
  EXPECT_EQ(summary["exploration_reason"], "every frontier explored");
  EXPECT_EQ(summary["suggestions_driven"].get<int>(), 11);
  EXPECT_THAT(r.err, HasSubstr("exploration done: every frontier explored: robot stopped"));
  EXPECT_THAT(r.err, HasSubstr(" explore="));
  EXPECT_THAT(r.err, HasSubstr(" targets="));
  EXPECT_EQ(server_.service().scans_received(), 12);
}

TEST_F(RobotLoopTest, CommandEndsAtStuckWithItsOwnExitCode) {
  server_.service().set_suggestion(Forward(/*duration=*/0.3));
  server_.service().set_exploration_end(3, v1::ExplorationProgress::STUCK,
                                        "no collision-free control");
  CliResult r = RunWaymark(server_.address(), {"robot", "--base", "sim:office", "--laser", "sim",
                                               "--mode", "active", "--sim-speed", "10"});
  EXPECT_EQ(r.code, kExitExplorationStuck) << r.err;
  EXPECT_EQ(kExitExplorationStuck, 3);  // documented in docs/robot.md
  EXPECT_THAT(r.out, HasSubstr("exploration stuck: no collision-free control: robot stopped"));
  EXPECT_THAT(r.out, HasSubstr("reconnects, exploration stuck"));
  r = RunWaymark(server_.address(), {"robot", "--base", "sim:office", "--laser", "sim", "--mode",
                                     "active", "--sim-speed", "10", "--json"});
  EXPECT_EQ(r.code, kExitExplorationStuck) << r.err;
  EXPECT_EQ(r.Json()["exploration_state"], "stuck");
  EXPECT_EQ(r.Json()["exploration_reason"], "no collision-free control");
}

// Issue 35: with the server gone at the end, the session cannot be closed: the last line must
// not say "closed" but that it is still open, and the exact command that closes it.
TEST_F(RobotLoopTest, CommandSaysTheSessionIsStillOpenWhenItCannotBeClosed) {
  server_.service().set_session_calls_fail(grpc::StatusCode::UNAVAILABLE);
  CliResult r = RunWaymark(server_.address(), {"robot", "--base", "sim:office", "--laser", "sim",
                                               "--duration", "2", "--sim-speed", "10"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, Not(HasSubstr("(closed)")));
  EXPECT_THAT(r.out, HasSubstr("could not close session s1: UNAVAILABLE"));
  EXPECT_THAT(r.out, HasSubstr("stopped: session s1 (STILL OPEN: could not close it (UNAVAILABLE"));
  EXPECT_THAT(r.out, HasSubstr("close it with `waymark --server " + server_.address() +
                               " slam close s1`"));
  r = RunWaymark(server_.address(), {"robot", "--base", "sim:office", "--laser", "sim",
                                     "--duration", "2", "--sim-speed", "10", "--json"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.Json()["session_closed"], false);
  EXPECT_THAT(r.Json()["close_error"].get<std::string>(), HasSubstr("UNAVAILABLE"));
  EXPECT_THAT(r.Json()["close_command"].get<std::string>(), HasSubstr("slam close s2"));
  EXPECT_THAT(r.err, HasSubstr("session s2 is STILL OPEN"));

  server_.service().set_session_calls_fail(grpc::StatusCode::OK);
  r = RunWaymark(server_.address(), {"robot", "--base", "sim:office", "--laser", "sim",
                                     "--duration", "2", "--sim-speed", "10"});
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_THAT(r.out, HasSubstr("stopped: session s3 (closed)"));
}

// Issue 35: --duration is the robot's clock; the help says it is simulated time with the
// simulator.
TEST_F(RobotLoopTest, DurationHelpSaysSimulatedSeconds) {
  CliResult r = RunWaymark(server_.address(), {"robot", "--help"});
  EXPECT_THAT(r.out + r.err, HasSubstr("simulated seconds with the simulator"));
}

TEST_F(RobotLoopTest, CommandErrorsAreClear) {
  CliResult r = RunWaymark(server_.address(), {"robot", "--base", "ttyS0", "--laser", "sim"});
  EXPECT_NE(r.code, 0);
  EXPECT_THAT(r.err, HasSubstr("serial:DEVICE"));
  r = RunWaymark(server_.address(),
                 {"robot", "--base", "sim:office", "--laser", "sim", "--camera", "0"});
  EXPECT_NE(r.code, 0);
  EXPECT_THAT(r.err, HasSubstr("--camera and --crossings go together"));
}

}  // namespace
}  // namespace waymark::cli
