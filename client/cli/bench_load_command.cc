// `waymark --server ADDR bench load --robots N --duration S [--json]`: a simulated fleet against
// one server (load_generator.h), reporting throughput, latency p50/p99 and errors by status code
// per RPC, and the server's memory.
//
// - Loopback only: a load test is for a server on this machine, never someone's production server
//   across the network. Bounded: at most kMaxRobots robots for kMaxDurationS seconds.
// - The robots recognize against a database the command creates and enrolls first (generated
//   images, or --images DIR) and deletes at the end (--keep-database keeps it), or against an
//   existing --database.
// - The server process: VmRSS sampled every second (start = after enrollment, peak, end), its
//   VmHWM, and the CPU time it used during the run (as cores kept busy). The process is the one
//   listening on the --server port (found through /proc; works for a server run by the same user
//   or when run as root), or --server-pid.
// - Progress every second on stderr; the report on stdout (a table, or JSON with --json).
// - Exit 1 when any call failed with anything but RESOURCE_EXHAUSTED (the documented answer of an
//   overloaded server), so a script can tell "overloaded" from "broken".
// Connections use the global --token and TLS options like every other command.

#include <fmt/format.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <ctime>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "absl/strings/str_cat.h"
#include "client/cli/command.h"
#include "client/load/load_generator.h"
#include "client/load/load_images.h"
#include "client/load/load_stats.h"
#include "client/common/output.h"
#include "client/cli/server_address.h"
#include "client/load/server_usage.h"
#include "client/common/stop_signals.h"

namespace waymark::cli {
namespace {

constexpr int kMaxRobots = 200;
constexpr double kMaxDurationS = 3600;
constexpr double kMiB = 1024.0 * 1024.0;

struct BenchLoadArgs {
  LoadOptions load;
  std::string database;  // existing database; empty = create one
  std::string images_dir;
  int server_pid = 0;  // 0 = find it from the port
  bool keep_database = false;
};

// The server process over the run: memory sampled every second by the progress thread, CPU time
// at the start and the end.
struct ServerUsage {
  std::optional<pid_t> pid;
  std::string note;  // why there is no pid
  std::optional<ProcessMemory> start, end;
  int64_t peak_rss_bytes = 0;
  std::optional<double> cpu_start_s, cpu_end_s;

  void Sample(bool is_start) {
    if (!pid) return;
    if (absl::StatusOr<ProcessMemory> memory = ReadProcessMemory(*pid); memory.ok()) {
      if (is_start) start = *memory;
      end = *memory;
      peak_rss_bytes = std::max(peak_rss_bytes, memory->rss_bytes);
    }
    if (absl::StatusOr<double> cpu = ReadProcessCpuSeconds(*pid); cpu.ok()) {
      if (is_start) cpu_start_s = *cpu;
      cpu_end_s = *cpu;
    }
  }

  std::optional<double> CpuSeconds() const {
    if (!cpu_start_s || !cpu_end_s) return std::nullopt;
    return *cpu_end_s - *cpu_start_s;
  }

  nlohmann::json Json(double elapsed_s) const {
    auto mib = [](const std::optional<ProcessMemory>& m, int64_t ProcessMemory::*field) {
      return m ? nlohmann::json((*m).*field / kMiB) : nlohmann::json(nullptr);
    };
    const std::optional<double> cpu = CpuSeconds();
    nlohmann::json out = {
        {"pid", pid ? nlohmann::json(*pid) : nlohmann::json(nullptr)},
        {"rss_start_mib", mib(start, &ProcessMemory::rss_bytes)},
        {"rss_peak_mib", end ? nlohmann::json(peak_rss_bytes / kMiB) : nlohmann::json(nullptr)},
        {"rss_end_mib", mib(end, &ProcessMemory::rss_bytes)},
        {"hwm_mib", mib(end, &ProcessMemory::peak_rss_bytes)},
        {"cpu_s", OptionalJson(cpu)},
        // Cores the server kept busy on average (user + system time over the run's wall time).
        {"cpu_cores", OptionalJson(cpu && elapsed_s > 0 ? std::optional<double>(*cpu / elapsed_s)
                                                        : std::nullopt)}};
    if (!note.empty()) out["note"] = note;
    return out;
  }
};

ServerUsage FindServer(const CommandContext& context, int server_pid) {
  ServerUsage track;
  if (server_pid > 0) {
    track.pid = server_pid;
    return track;
  }
  const std::optional<HostPort> address = ParseHostPort(context.globals.server);
  if (!address) {
    track.note = "no TCP port in the server address: pass --server-pid";
    return track;
  }
  absl::StatusOr<pid_t> pid = FindListeningProcess(address->port);
  if (pid.ok()) {
    track.pid = *pid;
  } else {
    track.note = absl::StrCat(pid.status().message(), ": pass --server-pid");
  }
  return track;
}

// Prints a progress line every second until Stop(), sampling the server's memory as it goes.
class Progress {
 public:
  Progress(std::ostream& err, const LoadRecorder& recorder, ServerUsage& memory, int robots)
      : err_(err), recorder_(recorder), memory_(memory), robots_(robots) {
    thread_ = std::thread([this] { Run(); });
  }
  ~Progress() { Stop(); }

  void Stop() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      stopped_ = true;
    }
    wake_.notify_all();
    if (thread_.joinable()) thread_.join();
  }

 private:
  void Run() {
    const auto start = std::chrono::steady_clock::now();
    LoadTotals last;
    std::unique_lock<std::mutex> lock(mutex_);
    for (int second = 1;; ++second) {
      if (wake_.wait_until(lock, start + std::chrono::seconds(second),
                           [this] { return stopped_; })) {
        break;
      }
      memory_.Sample(false);
      const LoadTotals now = recorder_.Totals();
      std::string line = fmt::format("[{:4d} s] {} robots: {} calls/s, {} errors", second, robots_,
                                     now.calls - last.calls, now.failed);
      if (memory_.end)
        line += fmt::format(", server RSS {:.1f} MiB", memory_.end->rss_bytes / kMiB);
      err_ << line << "\n" << std::flush;
      last = now;
    }
  }

  std::ostream& err_;
  const LoadRecorder& recorder_;
  ServerUsage& memory_;
  const int robots_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stopped_ = false;
  std::thread thread_;
};

// Creates `name` and enrolls `views` in one BulkEnroll stream.
absl::StatusOr<int> EnrollDatabase(client::CrossingClient& client, const std::string& name,
                                   const std::vector<LoadView>& views) {
  v1::CreateDatabaseRequest create;
  create.set_name(name);
  if (absl::StatusOr<v1::CrossingDatabase> created = client.CreateDatabase(create); !created.ok()) {
    return created.status();
  }
  std::unique_ptr<client::BulkEnrollWriter> writer = client.BulkEnroll();
  for (const LoadView& view : views) {
    v1::EnrollViewRequest request;
    request.set_database(name);
    request.set_crossing(view.crossing);
    request.set_heading_deg(view.heading_deg);
    request.set_create_crossing(true);
    request.set_skip_invalid(true);
    request.mutable_image()->set_data(view.bytes);
    if (!writer->Write(request)) break;  // Finish() says why
  }
  absl::StatusOr<v1::BulkEnrollResponse> enrolled = writer->Finish();
  if (!enrolled.ok()) return enrolled.status();
  return enrolled->views();
}

int RunBenchLoad(CommandContext& context, BenchLoadArgs args) {
  const std::string& server = context.globals.server;
  if (!IsLoopbackTarget(server)) {
    return ReportError(
        context, absl::InvalidArgumentError(
                     absl::StrCat("bench load only runs against a server on this machine; ", server,
                                  " is not a loopback address (use 127.0.0.1:PORT, "
                                  "[::1]:PORT or localhost:PORT)")));
  }
  absl::StatusOr<LoadImages> images =
      args.images_dir.empty() ? GeneratedLoadImages() : FolderLoadImages(args.images_dir);
  if (!images.ok()) return ReportError(context, images.status());

  std::unique_ptr<client::CrossingClient> client = context.Connect();
  const bool create = args.database.empty();
  int views_enrolled = 0;
  const auto setup_start = std::chrono::steady_clock::now();
  if (create) {
    args.load.database = fmt::format("bench-load-{}-{}", std::time(nullptr), getpid());
    context.err << "enrolling " << images->views.size() << " views into " << args.load.database
                << "\n";
    absl::StatusOr<int> enrolled = EnrollDatabase(*client, args.load.database, images->views);
    if (!enrolled.ok()) return ReportError(context, enrolled.status(), args.load.database);
    views_enrolled = *enrolled;
  } else {
    args.load.database = args.database;
    v1::GetDatabaseStatsRequest request;
    request.set_name(args.database);
    if (auto stats = client->GetDatabaseStats(request); !stats.ok()) {
      return ReportError(context, stats.status(), args.database);
    }
  }
  const double setup_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - setup_start).count();

  ServerUsage memory = FindServer(context, args.server_pid);
  memory.Sample(true);
  if (!memory.pid) context.err << "server memory and CPU not measured: " << memory.note << "\n";

  LoadRecorder recorder;
  StopSignals signals;  // Ctrl-C ends the run early; the report covers what ran
  absl::StatusOr<LoadResult> result;
  {
    Progress progress(context.err, recorder, memory, args.load.robots);
    result = RunLoad(
        args.load, images->queries,
        [&context] {
          return RobotClients{context.Connect(), context.ConnectSlam()};
        },
        recorder, signals.stop_requested());
  }
  memory.Sample(false);
  if (create && !args.keep_database) {
    v1::DeleteDatabaseRequest request;
    request.set_name(args.load.database);
    if (auto deleted = client->DeleteDatabase(request); !deleted.ok()) {
      ReportError(context, deleted.status(), "deleting " + args.load.database);
    }
  }
  if (!result.ok()) return ReportError(context, result.status());

  const std::map<std::string, RpcSummary> rpcs = recorder.Summarize(result->elapsed_s);
  const std::map<std::string, int64_t> errors = ErrorsByCode(rpcs);
  int64_t total_errors = 0, unexpected_errors = 0;
  for (const auto& [code, count] : errors) {
    total_errors += count;
    if (code != absl::StatusCodeToString(absl::StatusCode::kResourceExhausted)) {
      unexpected_errors += count;
    }
  }
  const LoadOptions& load = args.load;
  if (context.globals.json) {
    PrintJson(
        context.out,
        {{"server", server},
         {"robots", load.robots},
         {"duration_s", load.duration_s},
         {"elapsed_s", result->elapsed_s},
         {"rates_hz",
          {{"recognize", load.recognize_hz},
           {"scan", load.scan_hz},
           {"odometry", load.odometry_hz}}},
         {"database",
          {{"name", load.database},
           {"created", create},
           {"views_enrolled", views_enrolled},
           {"setup_s", setup_s},
           {"queries", images->queries.size()}}},
         {"rpcs", RpcSummariesJson(rpcs)},
         {"errors", {{"total", total_errors}, {"by_code", errors}}},
         {"recognition", {{"answered", result->recognitions}, {"recognized", result->recognized}}},
         {"slam",
          {{"sessions_created", result->sessions_created},
           {"sessions_closed", result->sessions_closed},
           {"scans_sent", result->scans_sent},
           {"scans_answered", result->scans_answered},
           {"scans_skipped", result->scans_skipped},
           {"odometry_sent", result->odometry_sent}}},
         {"server_process", memory.Json(result->elapsed_s)}});
  } else {
    context.out << fmt::format("{} robots for {:.1f} s against {} (database {}, {} query images)\n",
                               load.robots, result->elapsed_s, server, load.database,
                               images->queries.size());
    PrintRpcTable(context.out, rpcs);
    context.out << fmt::format(
        "recognitions: {} answered, {} recognized; SLAM: {} sessions, {} of {} scans answered "
        "({} skipped for too little motion), {} odometry\n",
        result->recognitions, result->recognized, result->sessions_created, result->scans_answered,
        result->scans_sent, result->scans_skipped, result->odometry_sent);
    context.out << "errors: " << total_errors << "\n";
    if (memory.end) {
      context.out << fmt::format(
          "server (pid {}): RSS {:.1f} MiB at start, {:.1f} peak, {:.1f} at end; high-water mark "
          "{:.1f} MiB; CPU {} s ({} cores)\n",
          *memory.pid, memory.start ? memory.start->rss_bytes / kMiB : 0.0,
          memory.peak_rss_bytes / kMiB, memory.end->rss_bytes / kMiB,
          memory.end->peak_rss_bytes / kMiB, FormatNumber(memory.CpuSeconds(), 1),
          FormatNumber(memory.CpuSeconds()
                           ? std::optional<double>(*memory.CpuSeconds() / result->elapsed_s)
                           : std::nullopt,
                       2));
    } else {
      context.out << "server memory and CPU: not measured (" << memory.note << ")\n";
    }
  }
  if (unexpected_errors > 0) {
    context.err << "error: " << unexpected_errors
                << " calls failed with codes other than RESOURCE_EXHAUSTED\n";
    return kExitFailure;
  }
  return kExitOk;
}

}  // namespace

void AddBenchLoadCommand(CLI::App& app, CommandRegistry& registry) {
  CLI::App* bench = app.add_subcommand("bench", "Measure a server on this machine");
  bench->require_subcommand(1);
  auto args = std::make_shared<BenchLoadArgs>();
  CLI::App* load = bench->add_subcommand(
      "load",
      "N simulated robots recognizing crossings and streaming SLAM sessions against a local "
      "server: throughput, latency p50/p99, errors by code, server memory");
  load->add_option("--robots", args->load.robots, "Simulated robots")
      ->required()
      ->check(CLI::Range(1, kMaxRobots));
  load->add_option("--duration", args->load.duration_s, "Seconds to run")
      ->required()
      ->check(CLI::Range(1.0, kMaxDurationS));
  load->add_option("--recognize-hz", args->load.recognize_hz,
                   "Recognitions per second per robot (0 = none)")
      ->check(CLI::Range(0.0, 30.0))
      ->capture_default_str();
  load->add_option("--scan-hz", args->load.scan_hz,
                   "Laser scans per second per robot (0 = no SLAM session)")
      ->check(CLI::Range(0.0, 75.0))
      ->capture_default_str();
  load->add_option("--odometry-hz", args->load.odometry_hz,
                   "Odometry messages per second per robot")
      ->check(CLI::Range(0.0, 50.0))
      ->capture_default_str();
  load->add_option("--world", args->load.world, "Simulator world the robots drive in")
      ->capture_default_str();
  load->add_option("--database", args->database,
                   "Recognize against this existing database instead of creating one");
  load->add_option("--images", args->images_dir,
                   "Images DIR/<crossing>/<heading>.jpg to enroll and recognize (default: "
                   "generated)")
      ->check(CLI::ExistingDirectory);
  load->add_option("--server-pid", args->server_pid,
                   "Server process for the memory report (default: the one listening on the "
                   "--server port)")
      ->check(CLI::PositiveNumber);
  load->add_flag("--keep-database", args->keep_database,
                 "Keep the database the run created (default: delete it)");
  registry.Add(load, [args](CommandContext& context) { return RunBenchLoad(context, *args); });
}

}  // namespace waymark::cli
