// waymark-robot-bench: how fast a driving robot is stopped when its server dies, and how fast
// it is streaming again once the server is back. The robot is the Pioneer and LMS200 drivers on
// pseudo-terminals to the test suite's fake ARCOS controller and fake LMS200 (the serial code a
// real robot runs); the server is the real waymark-server binary, killed with SIGKILL at a random
// moment of an active-mode run and restarted on the same port and database.
//
//   waymark-robot-bench [--trials 10] [--seed 1] [--json]
//
// Per trial: stop latency = kill -> the fake robot has received VEL 0 and RVEL 0 (polled every
// millisecond); resume latency = restart reported listening -> first answered scan on the resumed
// session. Reports median, p90 and max of each.
#include <fmt/format.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <csignal>
#include <nlohmann/json.hpp>
#include <random>
#include <thread>

#include "client/devices/lms200_scanner.h"
#include "client/devices/pioneer_base.h"
#include "client/common/steady_clock.h"
#include "client/lib/channel.h"
#include "client/robot/robot_loop.h"
#include "tests/robot/eventually.h"
#include "tests/robot/fake_arcos_peer.h"
#include "tests/robot/fake_lms200_peer.h"
#include "tests/support/server_process.h"

namespace waymark {
namespace {

using testing::Eventually;
using testing::FakeArcosPeer;

bool Stopped(const FakeArcosPeer& robot) { return robot.last_velocities() == std::make_pair(0, 0); }

struct Trial {
  double stop_ms = -1;
  double resume_ms = -1;
  bool ok = false;
  std::string error;
};

Trial Failed(std::string error) {
  Trial t;
  t.error = std::move(error);
  return t;
}

double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return -1;
  std::sort(v.begin(), v.end());
  return v[static_cast<size_t>(
      std::min<double>(v.size() - 1, std::floor(q * (v.size() - 1) + 0.5)))];
}

Trial RunTrial(const std::string& db, std::mt19937& rng) {
  Trial trial;
  auto server = testing::ServerProcess::Start(testing::ServerBinary(), db);
  if (!server.ok()) return Failed(server.status().ToString());
  auto pty = testing::PtyPair::Open();
  if (!pty.ok()) return Failed(pty.status().ToString());
  FakeArcosPeer robot(*std::move(pty));
  testing::FakeLms200Options laser_options;
  laser_options.scan_period = absl::Milliseconds(100);
  laser_options.range_mm = testing::RoomRangeMm;
  auto laser = testing::FakeLms200Peer::Start(laser_options);
  if (!laser.ok()) return Failed(laser.status().ToString());
  auto base = adapters::PioneerBase::Connect(robot.device_path());
  if (!base.ok()) return Failed(base.status().ToString());
  auto scanner = adapters::Lms200Scanner::Connect((*laser)->device_path());
  if (!scanner.ok()) return Failed(scanner.status().ToString());

  client::SlamClient client(client::MakeChannel((*server)->address()));
  cli::RobotLoopOptions options;
  options.robot_id = "bench";
  options.mode = cli::DriveMode::kActive;
  options.reconnect_initial = absl::Milliseconds(100);
  options.reconnect_max = absl::Milliseconds(500);
  cli::RobotLoop loop(client, **base, **scanner, options);
  std::atomic<bool> stop{false};
  absl::StatusOr<cli::RobotStatus> result;
  std::thread runner([&] { result = loop.Run(stop); });

  auto finish = [&](Trial t) {
    stop = true;
    runner.join();
    return t;
  };
  if (!Eventually([&] { return !Stopped(robot); }, absl::Seconds(30))) {
    return finish(Failed("the robot never moved"));
  }
  // Kill at a random moment of the 4 s hold.
  std::this_thread::sleep_for(
      std::chrono::duration<double>(std::uniform_real_distribution<double>(0.05, 3.5)(rng)));
  const bool moving = !Stopped(robot);
  const std::string address = (*server)->address();
  const double killed = adapters::SteadySeconds();
  (*server)->Stop(SIGKILL);
  while (!Stopped(robot) && adapters::SteadySeconds() - killed < 10) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  trial.stop_ms =
      moving ? 1000 * (adapters::SteadySeconds() - killed) : 0;  // a hold that had already ended: 0
  const uint64_t answered = loop.status().scans_answered;
  auto restarted = testing::ServerProcess::Start(testing::ServerBinary(), db, {}, address);
  if (!restarted.ok()) return finish(Failed(restarted.status().ToString()));
  const double listening = adapters::SteadySeconds();
  if (!Eventually([&] { return loop.status().scans_answered > answered; }, absl::Seconds(30))) {
    return finish(Failed("the loop did not resume"));
  }
  trial.resume_ms = 1000 * (adapters::SteadySeconds() - listening);
  trial = finish(trial);
  trial.ok = result.ok() && moving;
  if (!result.ok()) trial.error = result.status().ToString();
  if (!moving) trial.error = "the hold had ended before the kill";
  return trial;
}

}  // namespace
}  // namespace waymark

int main(int argc, char** argv) {
  CLI::App app{"Stop and resume latency of the robot loop when its server dies"};
  int trials = 10;
  unsigned seed = 1;
  bool json = false;
  app.add_option("--trials", trials)->check(CLI::Range(1, 1000));
  app.add_option("--seed", seed);
  app.add_flag("--json", json);
  CLI11_PARSE(app, argc, argv);

  const std::string dir = waymark::testing::MakeTempDir("robot-bench");
  std::mt19937 rng(seed);
  std::vector<double> stop_ms, resume_ms;
  int failed = 0, idle = 0;
  for (int i = 0; i < trials; ++i) {
    const std::string db = fmt::format("{}/trial{}.db", dir, i);
    waymark::Trial t = waymark::RunTrial(db, rng);
    if (t.stop_ms >= 0 && t.error == "the hold had ended before the kill") ++idle;
    if (t.ok) {
      stop_ms.push_back(t.stop_ms);
      resume_ms.push_back(t.resume_ms);
    } else if (t.error != "the hold had ended before the kill") {
      ++failed;
    }
    fmt::print(stderr, "trial {}: stop {:.1f} ms, resume {:.0f} ms {}\n", i + 1, t.stop_ms,
               t.resume_ms, t.error);
  }
  nlohmann::json out = {
      {"trials", trials},
      {"measured", stop_ms.size()},
      {"robot_not_moving_at_kill", idle},
      {"failed", failed},
      {"stop_ms",
       {{"p50", waymark::Quantile(stop_ms, 0.5)},
        {"p90", waymark::Quantile(stop_ms, 0.9)},
        {"max", waymark::Quantile(stop_ms, 1.0)}}},
      {"resume_ms",
       {{"p50", waymark::Quantile(resume_ms, 0.5)},
        {"p90", waymark::Quantile(resume_ms, 0.9)},
        {"max", waymark::Quantile(resume_ms, 1.0)}}},
  };
  if (json) {
    fmt::print("{}\n", out.dump(2));
  } else {
    fmt::print("server killed under a driving robot, {} of {} trials measured ({} failed)\n",
               stop_ms.size(), trials, failed);
    fmt::print("  robot stopped after  p50 {:.1f} ms  p90 {:.1f} ms  max {:.1f} ms\n",
               waymark::Quantile(stop_ms, 0.5), waymark::Quantile(stop_ms, 0.9),
               waymark::Quantile(stop_ms, 1.0));
    fmt::print(
        "  streaming again after p50 {:.0f} ms  p90 {:.0f} ms  max {:.0f} ms of the restart\n",
        waymark::Quantile(resume_ms, 0.5), waymark::Quantile(resume_ms, 0.9),
        waymark::Quantile(resume_ms, 1.0));
  }
  return failed == 0 ? 0 : 1;
}
