// waymark-hostile-campaign: a robustness campaign against a real waymark-server (issue 21).
//
//   waymark-hostile-campaign [--requests-per-rpc 10000] [--threads 4] [--seed 1]
//                            [--out out/bench/hostile_campaign] [--auth-requests 2000]
//                            [--deadline-seconds 30] [--idle-seconds 15] [--rpc-filter TEXT]
//
// Phase 1 starts waymark-server (auth off) on a fresh SQLite file, creates what valid requests
// address (crossing databases with views, SLAM sessions with scans, a token), then sends every
// RPC of every service in proto/ (enumerated from the generated descriptors) at least
// --requests-per-rpc malformed messages through grpc::GenericStub, from --threads clients at
// once: mutations of valid requests (hostile_campaign_mutations.h) in every call shape of the
// RPC's kind (hostile_campaign_shapes.h). Every call has a deadline; codes, latencies and
// anomalies are counted per RPC, the inputs behind anomalies kept under --out/samples. The
// server's resident memory is sampled every 100 ms; a server that exits is detected, its
// inputs kept under --out/crashes and replayed to find the killer, and it is restarted. At the
// end: is it alive, SERVING, does it still recognize a view and run a SLAM stream, its memory
// after --idle-seconds, and (after SIGTERM) PRAGMA integrity_check / foreign_key_check.
// Phase 2 (hostile_campaign_auth.h) attacks the authentication of a second server.
// Writes --out/hostile_campaign.json and prints a table.

#include <google/protobuf/stubs/logging.h>

#include <CLI/CLI.hpp>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <thread>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "bench/robustness/hostile_campaign_auth.h"
#include "bench/robustness/hostile_campaign_shapes.h"
#include "client/lib/channel.h"
#include "client/lib/crossing_client.h"
#include "client/lib/health_client.h"
#include "client/lib/slam_client.h"
#include "tests/service/slam_test_world.h"

namespace waymark::bench::hostile {
namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

struct Options {
  int64_t requests_per_rpc = 10000;
  int threads = 4;
  uint64_t seed = 1;
  std::string out = "out/bench/hostile_campaign";
  int64_t auth_requests = 2000;
  int deadline_seconds = 30;
  double idle_seconds = 15;
  std::string rpc_filter;
  bool replay_crashes = true;
  bool trace = false;
};

std::string Run(const std::string& command) {
  std::string output;
  if (FILE* pipe = popen(command.c_str(), "r")) {
    char buffer[4096];
    size_t n;
    while ((n = fread(buffer, 1, sizeof(buffer), pipe)) > 0) output.append(buffer, n);
    pclose(pipe);
  }
  while (!output.empty() && output.back() == '\n') output.pop_back();
  return output;
}

std::string FirstLine(const std::string& path, const std::string& prefix = "") {
  std::ifstream file(path);
  for (std::string line; std::getline(file, line);) {
    if (absl::StartsWith(line, prefix)) return line;
  }
  return "";
}

// What the numbers were measured on: the machine, its load, and the source the server was built
// from (the build directory is shared: uncommitted changes of others may be in the binary).
nlohmann::json MachineNote() {
  return {{"cores", std::thread::hardware_concurrency()},
          {"cpu", FirstLine("/proc/cpuinfo", "model name")},
          {"loadavg", FirstLine("/proc/loadavg")},
          {"source_commit", Run(absl::StrCat("git -C ", WAYMARK_SOURCE_DIR, " rev-parse --short HEAD"))},
          {"uncommitted_server_files",
           Run(absl::StrCat("git -C ", WAYMARK_SOURCE_DIR,
                            " status --porcelain -- server storage proto | tr '\\n' ' '"))}};
}

RunnerOptions RunnerSettings(const Options& options) {
  return {options.threads, std::chrono::seconds(options.deadline_seconds), options.seed,
          options.out, options.replay_crashes, options.trace ? options.out + "/calls.jsonl" : ""};
}

Batch HostileBatch(const RpcTarget& target, const Mutator& mutator, int64_t budget) {
  Batch batch;
  batch.name = target.name;
  batch.budget = budget;
  batch.plan = [&target, &mutator](int thread, Rng& rng, int64_t index) {
    return PlanHostileCall(target, mutator, thread, rng, index == 0);
  };
  batch.judge = JudgeHostile;
  return batch;
}

// The server still does its job: a view of an enrolled crossing is recognized.
nlohmann::json CheckRecognize(Fixtures& fixtures) {
  client::CrossingClient crossing(fixtures.channel());
  absl::StatusOr<v1::RecognizeResponse> answer = crossing.RecognizeCrossing(fixtures.KnownQuery());
  if (!answer.ok()) return {{"ok", false}, {"status", answer.status().ToString()}};
  return {{"ok", answer->recognized() && answer->crossing() == "crossing-1"},
          {"recognized", answer->recognized()},
          {"crossing", answer->crossing()},
          {"heading_deg", answer->heading_deg()}};
}

// ... and a new laser session streams: every scan answered, none rejected, poses finite.
nlohmann::json CheckSensorStream(Fixtures& fixtures) {
  client::SlamClient slam(fixtures.channel());
  absl::StatusOr<v1::Session> session = slam.CreateSession(Fixtures::LaserSession("final-check"));
  if (!session.ok()) return {{"ok", false}, {"status", session.status().ToString()}};
  std::atomic<int> updates{0}, rejected{0}, non_finite{0};
  std::unique_ptr<client::SensorStream> stream = slam.StreamSensorData(
      session->session_id(), client::kDefaultScanWindow, [&](const v1::SlamUpdate& update) {
        if (update.has_rejection()) {
          ++rejected;
          return;
        }
        ++updates;
        if (!std::isfinite(update.pose().x()) || !std::isfinite(update.pose().y())) ++non_finite;
      });
  constexpr int kScans = 20;
  for (int i = 0; i < kScans; ++i) {
    const double stamp = 1.0 + 0.5 * i, x = 0.03 * i;
    if (!stream->SendOdometry(testing::Odom(0, stamp, x, 0, 0).odometry()).ok() ||
        !stream->SendScan(testing::RoomScan(0, stamp + 0.01, x, 0, 0).scan()).ok()) {
      break;
    }
  }
  const absl::Status idle = stream->WaitIdle(absl::Seconds(60));
  const absl::Status finished = stream->Finish();
  return {{"ok", idle.ok() && finished.ok() && updates == kScans && rejected == 0 && non_finite == 0},
          {"scans", kScans}, {"updates", updates.load()}, {"rejected", rejected.load()},
          {"non_finite_poses", non_finite.load()}, {"status", finished.ToString()}};
}

nlohmann::json FinalChecks(WatchedServer& server, Fixtures& fixtures) {
  nlohmann::json checks = {{"alive", server.Alive()}};
  auto health = client::CheckHealth(fixtures.channel(), "", absl::Seconds(10));
  checks["health"] = health.ok()
                         ? grpc::health::v1::HealthCheckResponse::ServingStatus_Name(*health)
                         : health.status().ToString();
  checks["recognize"] = CheckRecognize(fixtures);
  checks["stream_sensor_data"] = CheckSensorStream(fixtures);
  return checks;
}

// Every anomaly of every row, biggest first, with where its inputs are kept.
nlohmann::json AnomalyList(const std::vector<std::pair<std::string, RpcStats>>& rows,
                           const nlohmann::json& samples) {
  nlohmann::json list = nlohmann::json::array();
  for (const auto& [name, stats] : rows) {
    for (const auto& [anomaly, count] : stats.anomalies()) {
      list.push_back({{"rpc", name}, {"anomaly", anomaly}, {"count", count}});
    }
  }
  std::sort(list.begin(), list.end(), [](const nlohmann::json& a, const nlohmann::json& b) {
    return a["count"].get<int64_t>() > b["count"].get<int64_t>();
  });
  return {{"list", list}, {"samples", samples}};
}

void FreshDirectory(const std::string& dir) {
  std::error_code ignored;
  fs::remove_all(dir, ignored);
  fs::create_directories(dir);
}

struct PhaseOne {
  std::vector<std::pair<std::string, RpcStats>> rows;
  nlohmann::json json;
};

PhaseOne RunHostilePhase(const Options& options, SampleSaver& samples) {
  PhaseOne phase;
  const std::string db = options.out + "/work/campaign.db";
  auto server = WatchedServer::Start(db, false);
  if (!server.ok()) {
    phase.json = {{"error", server.status().ToString()}};
    return phase;
  }
  std::fprintf(stderr, "server %s on %s; creating fixtures\n", (*server)->address().c_str(), db.c_str());
  auto fixtures = Fixtures::Create(client::MakeChannel((*server)->address()), options.threads);
  if (!fixtures.ok()) {
    phase.json = {{"error", "fixtures: " + fixtures.status().ToString()}};
    return phase;
  }
  std::vector<RpcTarget> targets = EnumerateTargets(**fixtures);
  const HostileImages images;
  const Mutator mutator(&images);
  Runner runner(server->get(), &samples, RunnerSettings(options));
  std::this_thread::sleep_for(std::chrono::seconds(2));
  const double rss_before = (*server)->RssMb();
  (*server)->ResetPeak();
  nlohmann::json rpcs = nlohmann::json::array();
  const auto campaign_start = Clock::now();
  double peak_mb = 0;  // over all batches (each batch's own peak is in its row)
  for (const RpcTarget& target : targets) {
    if (!options.rpc_filter.empty() && !absl::StrContains(target.name, options.rpc_filter)) continue;
    std::fprintf(stderr, "%s (%s)\n", target.name.c_str(), KindName(target.kind).c_str());
    const auto start = Clock::now();
    (*server)->ResetPeak();
    std::map<std::string, RpcStats> stats =
        runner.Run(HostileBatch(target, mutator, options.requests_per_rpc));
    if (target.after_batch) target.after_batch();
    const RpcStats& mine = stats[target.name];
    const double seconds = std::chrono::duration<double>(Clock::now() - start).count();
    nlohmann::json row = mine.ToJson();
    row["rpc"] = target.name;
    row["method"] = target.path;
    row["kind"] = KindName(target.kind);
    row["hand_made_requests"] = target.hand_made;
    row["seconds"] = seconds;
    row["rss_mb_after_batch"] = (*server)->RssMb();
    row["rss_mb_peak_during_batch"] = (*server)->PeakMb();
    peak_mb = std::max(peak_mb, (*server)->PeakMb());
    rpcs.push_back(row);
    phase.rows.emplace_back(target.name, mine);
    std::fprintf(stderr, "  %lld calls in %.0f s, RSS %.0f MB: %s\n",
                 static_cast<long long>(mine.calls()), seconds, row["rss_mb_after_batch"].get<double>(),
                 mine.CodesSummary().c_str());
  }
  const double campaign_seconds = std::chrono::duration<double>(Clock::now() - campaign_start).count();
  nlohmann::json memory = {{"before", rss_before},
                           {"peak_sampled", peak_mb},
                           {"peak_vmhwm", (*server)->KernelPeakMb()},
                           {"after", (*server)->RssMb()}};
  std::this_thread::sleep_for(std::chrono::duration<double>(options.idle_seconds));
  memory["after_idle"] = (*server)->RssMb();
  memory["idle_seconds"] = options.idle_seconds;
  nlohmann::json checks = FinalChecks(**server, **fixtures);
  checks["cleanups_failed"] = (*fixtures)->cleanups_failed();
  nlohmann::json crashes = nlohmann::json::array();
  for (const CrashRecord& crash : runner.crashes()) crashes.push_back(crash.ToJson());
  const nlohmann::json log = SummarizeLog((*server)->Log());
  checks["exit_code_on_sigterm"] = (*server)->Terminate();
  phase.json = {{"seconds", campaign_seconds}, {"rpcs", rpcs},        {"rss_mb", memory},
                {"crashes", crashes},          {"final_checks", checks}, {"log", log},
                {"database", CheckSqlite(db)}};
  return phase;
}

void PrintSummary(const nlohmann::json& phase, const char* title) {
  if (!phase.contains("rss_mb")) return;
  const nlohmann::json& m = phase["rss_mb"];
  std::printf("\n%s: server RSS MB before %.0f, peak %.0f (VmHWM %.0f), after %.0f, after %.0f s idle %.0f\n",
              title, m["before"].get<double>(), m["peak_sampled"].get<double>(),
              m["peak_vmhwm"].get<double>(), m["after"].get<double>(),
              m["idle_seconds"].get<double>(), m["after_idle"].get<double>());
  std::printf("crashes: %zu; final checks: %s\ndatabase: %s\n", phase["crashes"].size(),
              phase["final_checks"].dump().c_str(), phase["database"].dump().c_str());
}

int Main(const Options& options) {
  // Strings that are invalid UTF-8 on purpose would make protobuf log an error per message.
  google::protobuf::SetLogHandler(nullptr);
  fs::create_directories(options.out);
  FreshDirectory(options.out + "/work");
  FreshDirectory(options.out + "/samples");
  FreshDirectory(options.out + "/crashes");
  fs::remove(options.out + "/calls.jsonl");
  SampleSaver samples(options.out + "/samples", 5);
  nlohmann::json report = {
      {"options",
       {{"requests_per_rpc", options.requests_per_rpc}, {"threads", options.threads},
        {"seed", options.seed}, {"auth_requests_per_case", options.auth_requests},
        {"deadline_seconds", options.deadline_seconds}, {"rpc_filter", options.rpc_filter},
        {"operators", Mutator::OperatorNames()}}},
      {"machine_at_start", MachineNote()}};
  PhaseOne hostile = RunHostilePhase(options, samples);
  report["hostile"] = hostile.json;
  std::vector<std::pair<std::string, RpcStats>> rows = hostile.rows;
  if (options.auth_requests > 0) {
    AuthOptions auth;
    auth.requests_per_case = options.auth_requests;
    auth.runner = RunnerSettings(options);
    report["auth"] = RunAuthPhase(auth, &samples, &rows);
  }
  report["machine_at_end"] = {{"loadavg", FirstLine("/proc/loadavg")}};
  report["anomalies"] = AnomalyList(rows, samples.Index());
  std::ofstream(options.out + "/hostile_campaign.json") << report.dump(1) << "\n";
  PrintTable(rows, stdout);
  PrintSummary(report["hostile"], "hostile phase");
  std::printf("anomalies:\n");
  for (const nlohmann::json& a : report["anomalies"]["list"]) {
    std::printf("  %-40s %-36s %lld\n", a["rpc"].get<std::string>().c_str(),
                a["anomaly"].get<std::string>().c_str(), static_cast<long long>(a["count"].get<int64_t>()));
  }
  std::printf("report: %s/hostile_campaign.json\n", options.out.c_str());
  return hostile.json.contains("error") ? 1 : 0;
}

}  // namespace
}  // namespace waymark::bench::hostile

int main(int argc, char** argv) {
  waymark::bench::hostile::Options options;
  CLI::App app{"A robustness campaign of malformed requests against a real waymark-server"};
  app.add_option("--requests-per-rpc", options.requests_per_rpc,
                 "malformed messages per RPC (at least)")->capture_default_str();
  app.add_option("--threads", options.threads, "concurrent client threads")->check(CLI::Range(1, 64))->capture_default_str();
  app.add_option("--seed", options.seed)->capture_default_str();
  app.add_option("--out", options.out, "output directory")->capture_default_str();
  app.add_option("--auth-requests", options.auth_requests,
                 "calls per authentication case (0: no auth phase)")->capture_default_str();
  app.add_option("--deadline-seconds", options.deadline_seconds, "deadline of every call")
      ->check(CLI::Range(1, 600))->capture_default_str();
  app.add_option("--idle-seconds", options.idle_seconds, "idle time before the last memory sample")
      ->capture_default_str();
  app.add_option("--rpc-filter", options.rpc_filter, "only RPCs whose Service/Method contains this");
  app.add_flag("!--no-replay", options.replay_crashes, "do not replay a crash's inputs");
  app.add_flag("--trace", options.trace, "write every call to OUT/calls.jsonl");
  CLI11_PARSE(app, argc, argv);
  return waymark::bench::hostile::Main(options);
}
