// waymark-session-memory: what a server keeps of its SLAM sessions once they are closed (issue 38:
// 20 robots took a server from 66 to 262 MB; closing all their sessions gave back 23 MB).
//
//   waymark-session-memory [--server-binary PATH] [--baseline-binary PATH] [--robots 20]
//                          [--duration 180] [--runs 3] [--idle-seconds 15] [--scan-hz 5]
//                          [--odometry-hz 10] [--world office] [--out out/bench/session_memory]
//
// Each run starts a fresh server (--insecure-dev, its own SQLite file), lets it settle, then
// --robots simulated robots of `waymark bench load` (client/load/load_generator.h: one laser
// session each, odometry and scans from the simulator in real time, no recognition) stream for
// --duration seconds; each robot then finishes its stream and closes its session. The server's
// memory (/proc/PID/status: VmRSS, and RssAnon, its heap and stacks without the mapped code) is
// read before the robots start, sampled every 0.25 s for the peak, read as the last session is
// closed and again after --idle-seconds (the trimmer has had time to act). The sessions the server
// still holds in memory after the close are counted (ListSessions' resident flag): 0 expected.
//
// With --baseline-binary, runs alternate baseline and --server-binary (the same load in the same
// session, one server at a time); medians over --runs and the ratio new/baseline of each.
// Writes session_memory.json to --out and a table on stdout.

#include <fmt/format.h>
#include <signal.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <string>
#include <thread>
#include <vector>

#include "client/lib/channel.h"
#include "client/lib/crossing_client.h"
#include "client/lib/slam_client.h"
#include "client/load/load_generator.h"
#include "client/load/load_stats.h"
#include "tests/support/server_process.h"

namespace waymark::bench {
namespace {

using testing::ServerProcess;
using json = nlohmann::json;

struct Memory {
  double rss_mb = -1;   // VmRSS
  double anon_mb = -1;  // RssAnon
};

// /proc/PID/status; -1 for what cannot be read.
Memory ReadMemory(pid_t pid) {
  Memory memory;
  std::ifstream status(fmt::format("/proc/{}/status", pid));
  std::string key;
  double kb = 0;
  while (status >> key) {
    if (key == "VmRSS:" && status >> kb) memory.rss_mb = kb / 1024;
    if (key == "RssAnon:" && status >> kb) memory.anon_mb = kb / 1024;
    status.ignore(1 << 12, '\n');
  }
  return memory;
}

struct RunResult {
  std::string binary;
  Memory before, peak, at_close, after_idle;
  // While the robots stream: the heap at each quarter of the run (a lifelong map stays flat).
  std::vector<double> anon_quarters;
  int sessions_created = 0, sessions_closed = 0, resident_after_close = -1;
  int64_t scans_answered = 0;
};

json ToJson(const Memory& m) { return {{"rss_mb", m.rss_mb}, {"anon_mb", m.anon_mb}}; }

struct Options {
  cli::LoadOptions load;
  double idle_seconds = 15;
  double settle_seconds = 3;
};

absl::StatusOr<RunResult> RunOnce(const std::string& binary, const Options& options, int index) {
  const std::string dir = testing::MakeTempDir("waymark-session-memory");
  absl::StatusOr<std::unique_ptr<ServerProcess>> server =
      ServerProcess::Start(binary, dir + "/bench.db");
  if (!server.ok()) return server.status();
  const pid_t pid = (*server)->pid();
  const std::string address = (*server)->address();
  std::this_thread::sleep_for(std::chrono::duration<double>(options.settle_seconds));

  RunResult result;
  result.binary = binary;
  result.before = ReadMemory(pid);
  result.peak = result.before;
  std::atomic<bool> sampling{true};
  const auto start = std::chrono::steady_clock::now();
  std::thread sampler([&] {
    while (sampling.load()) {
      const Memory now = ReadMemory(pid);
      result.peak.rss_mb = std::max(result.peak.rss_mb, now.rss_mb);
      result.peak.anon_mb = std::max(result.peak.anon_mb, now.anon_mb);
      const double elapsed =
          std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
      const size_t quarter = result.anon_quarters.size() + 1;
      if (quarter <= 3 && elapsed >= options.load.duration_s * static_cast<double>(quarter) / 4) {
        result.anon_quarters.push_back(now.anon_mb);
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(250));
    }
  });
  cli::LoadRecorder recorder;
  std::atomic<bool> stop{false};
  absl::StatusOr<cli::LoadResult> load = cli::RunLoad(
      options.load, {},
      [&address] {
        // One channel per robot, as robots have.
        return cli::RobotClients{
            std::make_unique<client::CrossingClient>(client::MakeChannel(address)),
            std::make_unique<client::SlamClient>(client::MakeChannel(address))};
      },
      recorder, stop);
  result.at_close = ReadMemory(pid);
  sampling = false;
  sampler.join();
  result.anon_quarters.push_back(result.at_close.anon_mb);
  if (!load.ok()) return load.status();
  result.sessions_created = load->sessions_created;
  result.sessions_closed = load->sessions_closed;
  result.scans_answered = load->scans_answered;
  client::SlamClient slam(client::MakeChannel(address));
  if (absl::StatusOr<v1::ListSessionsResponse> listed = slam.ListSessions(); listed.ok()) {
    result.resident_after_close = 0;
    for (const v1::Session& session : listed->sessions()) {
      result.resident_after_close += session.resident() ? 1 : 0;
    }
  }
  std::this_thread::sleep_for(std::chrono::duration<double>(options.idle_seconds));
  result.after_idle = ReadMemory(pid);
  (*server)->Stop(SIGTERM);
  std::filesystem::remove_all(dir);
  std::cerr << fmt::format(
      "run {} {}: RSS {:.1f} -> peak {:.1f} -> {:.1f} at close -> {:.1f} after {:.0f} s idle MiB "
      "(anon {:.1f} -> {:.1f} -> {:.1f} -> {:.1f}); {} sessions closed, {} scans, {} resident\n",
      index, binary, result.before.rss_mb, result.peak.rss_mb, result.at_close.rss_mb,
      result.after_idle.rss_mb, options.idle_seconds, result.before.anon_mb, result.peak.anon_mb,
      result.at_close.anon_mb, result.after_idle.anon_mb, result.sessions_closed,
      result.scans_answered, result.resident_after_close);
  std::cerr << "  anon MiB at each quarter of the run:";
  for (double mb : result.anon_quarters) std::cerr << fmt::format(" {:.1f}", mb);
  std::cerr << (options.load.prune ? "\n" : " (sessions without pruning)\n");
  return result;
}

double Median(std::vector<double> values) {
  if (values.empty()) return -1;
  std::sort(values.begin(), values.end());
  const size_t n = values.size();
  return n % 2 == 1 ? values[n / 2] : (values[n / 2 - 1] + values[n / 2]) / 2;
}

// Medians over the runs of one binary, by measure.
json Medians(const std::vector<RunResult>& runs) {
  std::map<std::string, std::vector<double>> by;
  for (const RunResult& r : runs) {
    for (const auto& [name, m] : {std::pair<const char*, const Memory*>{"before", &r.before},
                                  {"peak", &r.peak},
                                  {"at_close", &r.at_close},
                                  {"after_idle", &r.after_idle}}) {
      by[std::string(name) + "_rss_mb"].push_back(m->rss_mb);
      by[std::string(name) + "_anon_mb"].push_back(m->anon_mb);
    }
    // What the close gave back of what the run gained (1 = all of it).
    const double gained = r.peak.anon_mb - r.before.anon_mb;
    by["returned_anon_fraction"].push_back(
        gained > 0 ? (r.peak.anon_mb - r.after_idle.anon_mb) / gained : -1);
  }
  json out;
  for (const auto& [name, values] : by) out[name] = Median(values);
  return out;
}

json RunJson(const RunResult& r) {
  return {{"binary", r.binary},
          {"before", ToJson(r.before)},
          {"peak", ToJson(r.peak)},
          {"at_close", ToJson(r.at_close)},
          {"after_idle", ToJson(r.after_idle)},
          {"anon_mb_at_quarters", r.anon_quarters},
          {"sessions_created", r.sessions_created},
          {"sessions_closed", r.sessions_closed},
          {"resident_after_close", r.resident_after_close},
          {"scans_answered", r.scans_answered}};
}

}  // namespace
}  // namespace waymark::bench

int main(int argc, char** argv) {
  using namespace waymark::bench;
  CLI::App app{"SLAM sessions of N robots opened, streamed and closed: the server's memory"};
  std::string server_binary = waymark::testing::ServerBinary(), baseline_binary, out_dir;
  out_dir = "out/bench/session_memory";
  int runs = 3;
  Options options;
  options.load.robots = 20;
  options.load.duration_s = 180;
  options.load.recognize_hz = 0;
  options.load.robot_prefix = "memory";
  app.add_option("--server-binary", server_binary, "the server measured")->capture_default_str();
  app.add_option("--baseline-binary", baseline_binary,
                 "a server to compare with, run alternately with --server-binary");
  bool baseline_no_pruning = false;
  app.add_flag("--baseline-no-pruning", baseline_no_pruning,
               "the baseline is --server-binary with sessions that keep every scan node "
               "(LaserSlamParams.prune_redundant_submaps = false)");
  app.add_option("--robots", options.load.robots)->check(CLI::Range(1, 200))->capture_default_str();
  app.add_option("--duration", options.load.duration_s, "seconds the robots stream")
      ->check(CLI::Range(1.0, 3600.0))
      ->capture_default_str();
  app.add_option("--runs", runs, "per binary")->check(CLI::Range(1, 20))->capture_default_str();
  app.add_option("--idle-seconds", options.idle_seconds, "after the close")
      ->check(CLI::Range(0.0, 600.0))
      ->capture_default_str();
  app.add_option("--scan-hz", options.load.scan_hz)->check(CLI::Range(0.1, 75.0))->capture_default_str();
  app.add_option("--odometry-hz", options.load.odometry_hz)
      ->check(CLI::Range(0.1, 50.0))
      ->capture_default_str();
  app.add_option("--world", options.load.world)->capture_default_str();
  app.add_option("--out", out_dir)->capture_default_str();
  CLI11_PARSE(app, argc, argv);

  if (baseline_no_pruning && !baseline_binary.empty()) {
    std::cerr << "--baseline-binary or --baseline-no-pruning, not both\n";
    return 2;
  }
  if (baseline_no_pruning) baseline_binary = server_binary;
  // (label, binary, prune), the baseline first; they alternate run by run.
  struct Config {
    std::string label, binary;
    bool prune = true;
  };
  std::vector<Config> configs;
  if (!baseline_binary.empty()) configs.push_back({"baseline", baseline_binary, !baseline_no_pruning});
  configs.push_back({"server", server_binary, true});
  std::map<std::string, std::vector<RunResult>> results;
  json runs_json = json::array();
  for (int run = 0; run < runs; ++run) {
    for (const Config& config : configs) {
      Options run_options = options;
      run_options.load.prune = config.prune;
      absl::StatusOr<RunResult> result = RunOnce(config.binary, run_options, run);
      if (!result.ok()) {
        std::cerr << "run " << run << " of " << config.binary << ": " << result.status() << "\n";
        return 1;
      }
      json run_json = RunJson(*result);
      run_json["label"] = config.label;
      run_json["prune"] = config.prune;
      runs_json.push_back(run_json);
      results[config.label].push_back(*std::move(result));
    }
  }

  json report = {{"robots", options.load.robots},
                 {"duration_s", options.load.duration_s},
                 {"scan_hz", options.load.scan_hz},
                 {"odometry_hz", options.load.odometry_hz},
                 {"world", options.load.world},
                 {"idle_seconds", options.idle_seconds},
                 {"runs", runs_json}};
  const json measured = Medians(results["server"]);
  report["server"] = {{"binary", server_binary}, {"medians", measured}};
  std::cout << fmt::format("{} robots x {:.0f} s at {} Hz scans, {} run(s) each; medians, MiB\n",
                           options.load.robots, options.load.duration_s, options.load.scan_hz, runs);
  std::cout << fmt::format("{:<26}{:>12}{:>12}{:>12}\n", "", "baseline", "server", "ratio");
  const json baseline = baseline_binary.empty() ? json() : Medians(results["baseline"]);
  if (!baseline_binary.empty()) {
    report["baseline"] = {{"binary", baseline_binary},
                          {"prune", !baseline_no_pruning},
                          {"medians", baseline}};
  }
  json ratios;
  for (const auto& [name, value] : measured.items()) {
    const double base = baseline.is_null() ? -1 : baseline[name].get<double>();
    const double ratio = base > 0 ? value.get<double>() / base : -1;
    if (base > 0) ratios[name] = ratio;
    std::cout << fmt::format("{:<26}{:>12.2f}{:>12.2f}{:>12.2f}\n", name, base, value.get<double>(),
                             ratio);
  }
  if (!ratios.is_null()) report["ratio_server_over_baseline"] = ratios;
  std::filesystem::create_directories(out_dir);
  std::ofstream(out_dir + "/session_memory.json") << report.dump(2) << "\n";
  std::cout << "wrote " << out_dir << "/session_memory.json\n";
  return 0;
}
