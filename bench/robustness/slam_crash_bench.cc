// waymark-slam-crash-bench: a SLAM session on a real laser log through a server that is SIGKILLed
// again and again, and what the journal costs (issue 21).
//
//   waymark-slam-crash-bench --log ../shared/data/laser/intel/intel.clf.bz2
//                            [--kills 20] [--scans 0] [--cost-scans 3000] [--cost-rounds 3]
//                            [--paper] [--seed N] [--out out/bench/slam_crash]
//
// Crash part: one server on a SQLite file (default checkpoints: 500 scans / 30 s); a robot streams
// the log's scans (odometry + scan per laser line, as `waymark slam replay`) with the client's
// default window; after a random 50-700 further answered scans the server is SIGKILLed with
// messages in flight, and started again on the same file. The robot reopens its stream, learns
// from StreamStart what the session holds, and resends from there. Per kill: the scans lost
// (answered before the kill but not held by the resumed session; the journal's target is 0), the
// time from the kill to the resumed stream's StreamStart (process start, database, checkpoint
// load, journal replay) and the journal replayed. At the end the session is closed and its
// trajectory compared with an uninterrupted session of the same scans on a fresh server.
//
// Cost part: the first --cost-scans scans into a fresh server with the journal on and off,
// alternating, --cost-rounds times each: the round trip of each scan sent alone (window 1, what a
// robot waiting for its pose sees) and the throughput with the default window. Medians over the
// rounds; the ratio on/off is measured in the same run.
//
// Writes slam_crash_bench.json to --out.

#include <fmt/format.h>
#include <signal.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <memory>
#include <map>
#include <mutex>
#include <numeric>
#include <nlohmann/json.hpp>
#include <random>
#include <string>
#include <thread>
#include <vector>

#include "client/datasets/carmen_laser_feed.h"
#include "client/lib/channel.h"
#include "client/lib/slam_client.h"
#include "client/sessions/slam_replay.h"
#include "tests/support/server_process.h"

namespace waymark::bench {
namespace {

using Clock = std::chrono::steady_clock;
using cli::ReplayStep;
using testing::ServerProcess;

double Seconds(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double>(b - a).count();
}

double Quantile(std::vector<double> values, double q) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  return values[static_cast<size_t>(q * static_cast<double>(values.size() - 1) + 0.5)];
}

struct Log {
  std::vector<ReplayStep> steps;
  v1::CreateSessionRequest create;
};

absl::StatusOr<Log> LoadLog(const std::string& path, int max_scans, bool paper) {
  auto reader = adapters::CarmenLogReader::Open(path);
  if (!reader.ok()) return reader.status();
  adapters::CarmenLaserFeed feed(*std::move(reader));
  Log log;
  adapters::CarmenRecord record;
  while (max_scans <= 0 || static_cast<int>(log.steps.size()) < max_scans) {
    absl::StatusOr<bool> more = feed.Next(&record);
    if (!more.ok()) return more.status();
    if (!*more) break;
    if (log.steps.empty()) {
      cli::ReplayArgs args;
      args.log = path;
      args.robot_id = "crash-bench";
      log.create = cli::SessionRequest(args, record.laser);
      if (paper) log.create.mutable_laser()->mutable_params()->set_loop_closure(false);
    }
    log.steps.push_back(cli::ReplayStepOf(record.laser));
  }
  if (log.steps.empty()) return absl::InvalidArgumentError("the log has no laser lines");
  return log;
}

// The server binary (--server-binary; a copy keeps a long run safe from a rebuild).
std::string& ServerBinaryPath() {
  static std::string path = testing::ServerBinary();
  return path;
}

absl::StatusOr<std::unique_ptr<ServerProcess>> StartServer(const std::string& db,
                                                           std::vector<std::string> args = {}) {
  args.insert(args.begin(), {"--slam-workers", "2"});
  return ServerProcess::Start(ServerBinaryPath(), db, args);
}

// The first step whose stamp is after `stamp` (what a resumed session does not hold yet).
size_t FirstAfter(const std::vector<ReplayStep>& steps, double stamp) {
  return static_cast<size_t>(
      std::upper_bound(steps.begin(), steps.end(), stamp,
                       [](double s, const ReplayStep& step) { return s < step.scan.stamp(); }) -
      steps.begin());
}

// Streams steps[from, to) and waits for the answers; window 1 records each scan's round trip.
struct StreamRun {
  absl::Status status;
  double seconds = 0;
  std::vector<double> round_trip_ms;
};

StreamRun Stream(client::SlamClient& slam, const std::string& id,
                 const std::vector<ReplayStep>& steps, size_t from, size_t to, int window) {
  StreamRun run;
  std::mutex mu;
  std::vector<Clock::time_point> answered;
  auto stream = slam.StreamSensorData(id, window, [&](const v1::SlamUpdate&) {
    std::lock_guard<std::mutex> lock(mu);
    answered.push_back(Clock::now());
  });
  std::vector<Clock::time_point> sent;
  const Clock::time_point start = Clock::now();
  for (size_t i = from; i < to && run.status.ok(); ++i) {
    run.status = stream->SendOdometry(steps[i].odometry);
    if (run.status.ok()) {
      sent.push_back(Clock::now());
      run.status = stream->SendScan(steps[i].scan);
    }
  }
  const absl::Status finished = stream->Finish();
  if (run.status.ok()) run.status = finished;
  run.seconds = Seconds(start, Clock::now());
  if (window == 1) {
    std::lock_guard<std::mutex> lock(mu);
    for (size_t i = 0; i < std::min(sent.size(), answered.size()); ++i) {
      run.round_trip_ms.push_back(1e3 * Seconds(sent[i], answered[i]));
    }
  }
  return run;
}

absl::StatusOr<v1::Trajectory> CloseAndRead(client::SlamClient& slam, const std::string& id) {
  if (absl::StatusOr<v1::Session> closed = slam.CloseSession(id); !closed.ok()) {
    return closed.status();
  }
  return slam.GetTrajectory(id);
}

// A fresh server and session, every scan streamed at once, closed: its trajectory.
absl::StatusOr<v1::Trajectory> Uninterrupted(const Log& log, const std::string& db) {
  std::filesystem::remove(db);
  auto server = StartServer(db);
  if (!server.ok()) return server.status();
  client::SlamClient slam(client::MakeChannel((*server)->address()));
  absl::StatusOr<v1::Session> session = slam.CreateSession(log.create);
  if (!session.ok()) return session.status();
  StreamRun run = Stream(slam, session->session_id(), log.steps, 0, log.steps.size(),
                         client::kDefaultScanWindow);
  if (!run.status.ok()) return run.status;
  return CloseAndRead(slam, session->session_id());
}

// How far apart two trajectories of the same scans are, printed and as JSON.
nlohmann::json Compare(const v1::Trajectory& a, const v1::Trajectory& b, const std::string& what) {
  double dxy = 0, dtheta = 0;
  int equal = 0;
  const int n = std::min(a.poses_size(), b.poses_size());
  for (int i = 0; i < n; ++i) {
    const v1::Pose2D& p = a.poses(i).pose();
    const v1::Pose2D& q = b.poses(i).pose();
    dxy = std::max(dxy, std::hypot(p.x() - q.x(), p.y() - q.y()));
    dtheta = std::max(dtheta, std::abs(std::remainder(p.theta() - q.theta(), 2 * M_PI)));
    if (p.x() == q.x() && p.y() == q.y() && p.theta() == q.theta()) ++equal;
  }
  std::cout << fmt::format(
      "{} against an uninterrupted one: {} / {} poses, {} identical, max difference {:.3g} m, "
      "{:.3g} rad\n",
      what, a.poses_size(), b.poses_size(), equal, dxy, dtheta);
  return {{"poses", a.poses_size()},
          {"reference_poses", b.poses_size()},
          {"identical_poses", equal},
          {"max_position_difference_m", dxy},
          {"max_heading_difference_rad", dtheta}};
}

struct KillResult {
  int64_t answered = 0;  // the last answer's scan count before the kill
  int64_t resumed = 0;   // what the resumed session held
  double restart_s = 0;  // kill -> StreamStart of the resumed stream
  double server_start_s = 0;
};

int Run(int argc, char** argv) {
  CLI::App app{"SLAM sessions through SIGKILLs and what the journal costs (issue 21)"};
  std::string log_path;
  int kills = 20, max_scans = 0, cost_scans = 3000, cost_rounds = 3;
  bool paper = false;
  unsigned seed = std::random_device{}();
  std::string out = "out/bench/slam_crash";
  app.add_option("--log", log_path, "CARMEN log")->required();
  app.add_option("--kills", kills, "SIGKILLs during the stream")->capture_default_str();
  app.add_option("--scans", max_scans, "use the log's first N scans (0 = all)");
  app.add_option("--cost-scans", cost_scans, "scans per journal cost run")->capture_default_str();
  app.add_option("--cost-rounds", cost_rounds, "journal on/off runs each")->capture_default_str();
  app.add_flag("--paper", paper, "sessions without loop closure (the paper's EKF alone)");
  app.add_option("--seed", seed, "kill points");
  app.add_option("--out", out, "output folder")->capture_default_str();
  app.add_option("--server-binary", ServerBinaryPath(), "waymark-server to run")
      ->capture_default_str();
  CLI11_PARSE(app, argc, argv);
  std::filesystem::create_directories(out);
  absl::StatusOr<Log> log = LoadLog(log_path, max_scans, paper);
  if (!log.ok()) {
    std::cerr << log.status() << "\n";
    return 1;
  }
  const std::vector<ReplayStep>& steps = log->steps;
  std::cout << fmt::format("{}: {} scans, seed {}\n", log_path, steps.size(), seed);
  nlohmann::json report;
  report["log"] = log_path;
  report["scans"] = steps.size();
  report["seed"] = seed;
  report["paper"] = paper;

  // --- crashes ------------------------------------------------------------------------------
  const std::string crash_db = out + "/crash.db";
  std::filesystem::remove(crash_db);
  std::filesystem::remove(crash_db + "-wal");
  std::filesystem::remove(crash_db + "-shm");
  auto server = StartServer(crash_db);
  if (!server.ok()) {
    std::cerr << server.status() << "\n";
    return 1;
  }
  std::string id;
  {
    client::SlamClient slam(client::MakeChannel((*server)->address()));
    absl::StatusOr<v1::Session> session = slam.CreateSession(log->create);
    if (!session.ok()) {
      std::cerr << session.status() << "\n";
      return 1;
    }
    id = session->session_id();
  }
  std::mt19937 rng(seed);
  std::uniform_int_distribution<int> further(50, 700);
  std::vector<KillResult> results;
  Clock::time_point killed_at;
  int64_t answered_before = 0;
  size_t next = 0;
  for (int trial = 0; trial <= kills; ++trial) {
    client::SlamClient slam(client::MakeChannel((*server)->address()));
    std::atomic<int64_t> answered{0};
    auto stream = slam.StreamSensorData(id, client::kDefaultScanWindow, [&](const v1::SlamUpdate& u) {
      if (!u.has_rejection()) answered = static_cast<int64_t>(u.scans_processed());
    });
    absl::StatusOr<v1::StreamStart> start = stream->Hello(absl::Seconds(600));
    if (!start.ok()) {
      std::cerr << "resume: " << start.status() << "\n" << (*server)->Log();
      return 1;
    }
    if (trial > 0) {
      KillResult& result = results.back();
      result.resumed = static_cast<int64_t>(start->scans_processed());
      result.restart_s = Seconds(killed_at, Clock::now());
      std::cout << fmt::format(
          "kill {:2}: answered {:5} scans, resumed with {:5} (lost {}), back in {:.2f} s "
          "(server up in {:.2f} s)\n",
          trial, result.answered, result.resumed, result.answered - result.resumed,
          result.restart_s, result.server_start_s);
      next = FirstAfter(steps, start->last_scan_stamp());
    }
    if (trial == kills) {
      // The rest of the log, then the final state.
      for (size_t i = next; i < steps.size(); ++i) {
        if (!stream->SendOdometry(steps[i].odometry).ok()) break;
        if (!stream->SendScan(steps[i].scan).ok()) break;
      }
      if (absl::Status s = stream->Finish(); !s.ok()) {
        std::cerr << "last stream: " << s << "\n";
        return 1;
      }
      break;
    }
    // Sends on this thread until the kill breaks the stream; a watcher kills after the target.
    const int64_t target = static_cast<int64_t>(start->scans_processed()) + further(rng);
    std::atomic<bool> killed{false};
    std::thread killer([&] {
      while (answered < target && !stream->ended()) {
        std::this_thread::sleep_for(std::chrono::microseconds(200));
      }
      killed_at = Clock::now();
      (*server)->Signal(SIGKILL);
      killed = true;
    });
    for (size_t i = next; i < steps.size() && !killed; ++i) {
      if (!stream->SendOdometry(steps[i].odometry).ok()) break;
      if (!stream->SendScan(steps[i].scan).ok()) break;
    }
    killer.join();
    (void)stream->Finish();  // broken by the kill
    answered_before = answered;
    (*server)->WaitForExit(absl::Seconds(60));
    if (answered_before < target) {
      // Killed once the whole log was answered: the next stream is the last one.
      std::cout << "the log ended before kill " << trial + 1 << "'s target\n";
      kills = trial + 1;
    }
    KillResult result;
    result.answered = answered_before;
    const Clock::time_point restarting = Clock::now();
    server = StartServer(crash_db);
    if (!server.ok()) {
      std::cerr << "restart: " << server.status() << "\n";
      return 1;
    }
    result.server_start_s = Seconds(restarting, Clock::now());
    results.push_back(result);
  }
  absl::StatusOr<v1::Trajectory> crashed;
  {
    client::SlamClient slam(client::MakeChannel((*server)->address()));
    crashed = CloseAndRead(slam, id);
  }
  server->reset();

  // --- the same scans uninterrupted, twice: with loop closure the back end's optimisations land
  // when their thread is done (not deterministic), so two uninterrupted runs differ too ----------
  absl::StatusOr<v1::Trajectory> reference = Uninterrupted(*log, out + "/reference.db");
  absl::StatusOr<v1::Trajectory> again = Uninterrupted(*log, out + "/reference-again.db");
  nlohmann::json crash;
  std::vector<double> lost, restart, server_start;
  for (const KillResult& r : results) {
    // Negative: the server had processed scans whose answers the kill kept from the robot.
    lost.push_back(static_cast<double>(std::max<int64_t>(0, r.answered - r.resumed)));
    restart.push_back(r.restart_s);
    server_start.push_back(r.server_start_s);
    crash["kills"].push_back({{"answered", r.answered},
                              {"resumed", r.resumed},
                              {"restart_s", r.restart_s},
                              {"server_start_s", r.server_start_s}});
  }
  crash["lost_total"] = std::accumulate(lost.begin(), lost.end(), 0.0);
  crash["lost_max"] = lost.empty() ? 0 : *std::max_element(lost.begin(), lost.end());
  crash["restart_s_median"] = Quantile(restart, 0.5);
  crash["restart_s_max"] = Quantile(restart, 1.0);
  crash["server_start_s_median"] = Quantile(server_start, 0.5);
  std::cout << fmt::format(
      "{} kills: {} scans lost in all (max {} per kill); back after a kill in {:.2f} s median, "
      "{:.2f} s max (server up in {:.2f} s)\n",
      results.size(), crash["lost_total"].get<double>(), crash["lost_max"].get<double>(),
      Quantile(restart, 0.5), Quantile(restart, 1.0), Quantile(server_start, 0.5));
  if (crashed.ok() && reference.ok() && again.ok()) {
    crash["resumed_vs_uninterrupted"] = Compare(*crashed, *reference, "resumed session");
    crash["uninterrupted_vs_uninterrupted"] =
        Compare(*again, *reference, "a second uninterrupted one");
  } else {
    std::cerr << "trajectories: " << crashed.status() << " / " << reference.status() << " / "
              << again.status() << "\n";
  }
  report["crash"] = crash;

  // --- what the journal costs ----------------------------------------------------------------
  const size_t cost_end = std::min(steps.size(), static_cast<size_t>(std::max(1, cost_scans)));
  std::map<bool, std::vector<double>> p50, p90, rate;
  for (int round = 0; round < cost_rounds; ++round) {
    for (bool journal : {true, false}) {
      const std::string db = out + fmt::format("/cost-{}.db", journal ? "on" : "off");
      std::filesystem::remove(db);
      auto cost_server = StartServer(db, {"--slam-journal", journal ? "true" : "false"});
      if (!cost_server.ok()) return 1;
      client::SlamClient slam(client::MakeChannel((*cost_server)->address()));
      absl::StatusOr<v1::Session> lockstep = slam.CreateSession(log->create);
      absl::StatusOr<v1::Session> windowed = slam.CreateSession(log->create);
      if (!lockstep.ok() || !windowed.ok()) return 1;
      StreamRun alone = Stream(slam, lockstep->session_id(), steps, 0, cost_end, 1);
      StreamRun fast = Stream(slam, windowed->session_id(), steps, 0, cost_end,
                              client::kDefaultScanWindow);
      p50[journal].push_back(Quantile(alone.round_trip_ms, 0.5));
      p90[journal].push_back(Quantile(alone.round_trip_ms, 0.9));
      rate[journal].push_back(static_cast<double>(cost_end) / fast.seconds);
      std::cout << fmt::format(
          "journal {:3}: round trip p50 {:.2f} ms, p90 {:.2f} ms; {:.0f} scans/s windowed\n",
          journal ? "on" : "off", p50[journal].back(), p90[journal].back(), rate[journal].back());
    }
  }
  nlohmann::json cost;
  for (bool journal : {true, false}) {
    const std::string key = journal ? "on" : "off";
    cost[key] = {{"round_trip_ms_p50", Quantile(p50[journal], 0.5)},
                 {"round_trip_ms_p90", Quantile(p90[journal], 0.5)},
                 {"scans_per_s", Quantile(rate[journal], 0.5)}};
  }
  if (cost_rounds > 0) {
    std::cout << fmt::format(
        "journal cost (medians of {} rounds, {} scans): round trip p50 {:.2f} vs {:.2f} ms "
        "(x{:.2f}), p90 {:.2f} vs {:.2f} ms; windowed {:.0f} vs {:.0f} scans/s (x{:.2f})\n",
        cost_rounds, cost_end, Quantile(p50[true], 0.5), Quantile(p50[false], 0.5),
        Quantile(p50[true], 0.5) / Quantile(p50[false], 0.5), Quantile(p90[true], 0.5),
        Quantile(p90[false], 0.5), Quantile(rate[true], 0.5), Quantile(rate[false], 0.5),
        Quantile(rate[true], 0.5) / Quantile(rate[false], 0.5));
  }
  report["journal_cost"] = cost;
  std::ofstream(out + "/slam_crash_bench.json") << report.dump(2) << "\n";
  return 0;
}

}  // namespace
}  // namespace waymark::bench

int main(int argc, char** argv) { return waymark::bench::Run(argc, argv); }
