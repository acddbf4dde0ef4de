#include "server/service/operations/metrics.h"

#include "server/service/runtime/thread_stack_floor.h"

#include <arpa/inet.h>
#include <netinet/in.h>
#include <prometheus/client_metric.h>
#include <prometheus/collectable.h>
#include <prometheus/counter.h>
#include <prometheus/exposer.h>
#include <prometheus/family.h>
#include <prometheus/gauge.h>
#include <prometheus/histogram.h>
#include <prometheus/metric_family.h>
#include <prometheus/registry.h>
#include <prometheus/text_serializer.h>
#include <spdlog/spdlog.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <map>
#include <mutex>
#include <set>
#include <chrono>
#include <cstdint>
#include <exception>
#include <filesystem>
#include <system_error>
#include <thread>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"

namespace waymark::service {
namespace {

// 1 ms (a cache-hit list call) to 30 s (a recognition against a large database on a slow
// machine); streams that outlive 30 s land in +Inf.
const prometheus::Histogram::BucketBoundaries& LatencyBuckets() {
  static const auto* buckets = new prometheus::Histogram::BucketBoundaries{
      0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1, 2.5, 5, 10, 30};
  return *buckets;
}

prometheus::MetricFamily GaugeFamily(std::string name, std::string help) {
  prometheus::MetricFamily family;
  family.name = std::move(name);
  family.help = std::move(help);
  family.type = prometheus::MetricType::Gauge;
  return family;
}

void AddGauge(prometheus::MetricFamily& family, double value,
              std::vector<prometheus::ClientMetric::Label> labels = {}) {
  prometheus::ClientMetric metric;
  metric.label = std::move(labels);
  metric.gauge.value = value;
  family.metric.push_back(std::move(metric));
}

// Bytes of a file, 0 when it does not exist (a WAL is absent after a clean checkpoint).
std::uintmax_t FileBytes(const std::string& path) {
  std::error_code error;
  const std::uintmax_t bytes = std::filesystem::file_size(path, error);
  return error ? 0 : bytes;
}

// IPV4:PORT, checked here so a typo gets a precise message instead of civetweb's "possible
// problem binding to port". Debian's civetweb is built without IPv6 (mg_check_feature(8) is 0),
// so [IPV6]:PORT cannot be served.
absl::Status CheckListen(const std::string& listen) {
  const std::string usage = absl::StrCat(
      "metrics address \"", listen, "\" must be IPV4:PORT, e.g. 0.0.0.0:9100 or 127.0.0.1:9100");
  const size_t colon = listen.rfind(':');
  if (colon == std::string::npos) return absl::InvalidArgumentError(usage);
  if (listen.front() == '[') {
    return absl::InvalidArgumentError(
        absl::StrCat(usage, " (the metrics endpoint has no IPv6 support)"));
  }
  in_addr ip{};
  int port = 0;
  if (inet_pton(AF_INET, listen.substr(0, colon).c_str(), &ip) != 1 ||
      !absl::SimpleAtoi(listen.substr(colon + 1), &port) || port < 0 || port > 65535) {
    return absl::InvalidArgumentError(usage);
  }
  return absl::OkStatus();
}

// One TCP connection to the endpoint, closed at once; 0.0.0.0 is reached on loopback.
void TouchListener(const std::string& host, int port) {
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_port = htons(static_cast<uint16_t>(port));
  if (inet_pton(AF_INET, host.c_str(), &address.sin_addr) != 1) return;
  if (address.sin_addr.s_addr == htonl(INADDR_ANY))
    address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  const int fd = socket(AF_INET, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0) return;
  connect(fd, reinterpret_cast<const sockaddr*>(&address), sizeof(address));
  close(fd);
}

// civetweb's listener thread polls its sockets with a 2 s timeout and sees a stop request only
// when the poll returns, so destroying an Exposer takes up to 2 s: at every SIGTERM and in every
// test. Connecting to the listener while it stops makes the poll return at once.
void StopExposer(std::unique_ptr<prometheus::Exposer> exposer, const std::string& host, int port) {
  if (exposer == nullptr) return;
  std::atomic<bool> stopped{false};
  std::thread waker([&] {
    while (!stopped.load()) {
      TouchListener(host, port);
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
  });
  exposer.reset();
  stopped = true;
  waker.join();
}

}  // namespace

// gRPC and absl share the code numbers, so absl's names are gRPC's.
std::string StatusCodeName(grpc::StatusCode code) {
  std::string name = absl::StatusCodeToString(static_cast<absl::StatusCode>(code));
  return name.empty() ? absl::StrCat(static_cast<int>(code)) : name;
}

namespace {

// Processing time of one scan (or frame) in a SLAM session: 0.5 ms (a scan the EKF alone takes)
// to 2.5 s (a loop search on a loaded machine).
const prometheus::Histogram::BucketBoundaries& ScanBuckets() {
  static const auto* buckets = new prometheus::Histogram::BucketBoundaries{
      0.0005, 0.001, 0.0025, 0.005, 0.01, 0.025, 0.05, 0.1, 0.25, 0.5, 1, 2.5};
  return *buckets;
}

// The q-quantile (0..1) of `values` (not empty), nearest rank.
double Quantile(std::vector<double> values, double q) {
  std::sort(values.begin(), values.end());
  const size_t rank = static_cast<size_t>(std::ceil(q * static_cast<double>(values.size())));
  return values[std::min(values.size() - 1, rank == 0 ? 0 : rank - 1)];
}

}  // namespace

// The SLAM answers as they go out (SlamRegistry::SetUpdateObserver): the server-wide scan count
// and processing-time histogram (no labels), and per session what its last answer said and the
// processing times of its last kWindow scans, for the per-session gauges. A session's entry is
// dropped at the first scrape after it left memory (closed, deleted, handed to another server), so
// the `session` label takes at most as many values as sessions in memory (--max-sessions).
// Shared with the registry's observer, which may run on a worker thread while ~Metrics runs.
class Metrics::SlamSessionStats {
 public:
  static constexpr size_t kWindow = 256;
  struct Entry {
    uint64_t loop_closures = 0;
    std::vector<double> recent_seconds;  // a ring of the last kWindow processing times
    size_t next = 0;
  };

  explicit SlamSessionStats(prometheus::Registry& registry)
      : scans_(&prometheus::BuildCounter()
                    .Name("waymark_slam_scans_total")
                    .Help("SLAM scans (and visual frames) processed and answered, all sessions")
                    .Register(registry)
                    .Add({})),
        seconds_(&prometheus::BuildHistogram()
                      .Name("waymark_slam_scan_seconds")
                      .Help("Processing time of one SLAM scan or frame in its session, queue "
                            "excluded, all sessions")
                      .Register(registry)
                      .Add({}, ScanBuckets())) {}

  void Observe(const std::string& session_id, const v1::SlamUpdate& update) {
    const double seconds = std::max(0.0, update.timings().total_ms() / 1000);
    scans_->Increment();
    seconds_->Observe(seconds);
    std::lock_guard<std::mutex> lock(mutex_);
    Entry& entry = sessions_[session_id];
    entry.loop_closures = update.loop_closures();
    if (entry.recent_seconds.size() < kWindow) {
      entry.recent_seconds.push_back(seconds);
    } else {
      entry.recent_seconds[entry.next] = seconds;
      entry.next = (entry.next + 1) % kWindow;
    }
  }

  // A session left memory (SlamReleasedObserver): its entry goes at once, not at the next scrape
  // (a server nobody scrapes would keep one per session it ever held).
  void Forget(const std::string& session_id) {
    std::lock_guard<std::mutex> lock(mutex_);
    sessions_.erase(session_id);
  }

  size_t size() {
    std::lock_guard<std::mutex> lock(mutex_);
    return sessions_.size();
  }

  // The entries of the sessions in `resident`; every other entry is dropped.
  std::map<std::string, Entry> Keep(const std::set<std::string>& resident) {
    std::lock_guard<std::mutex> lock(mutex_);
    for (auto it = sessions_.begin(); it != sessions_.end();) {
      it = resident.count(it->first) ? std::next(it) : sessions_.erase(it);
    }
    return sessions_;
  }

 private:
  prometheus::Counter* scans_;
  prometheus::Histogram* seconds_;
  std::mutex mutex_;
  std::map<std::string, Entry> sessions_;
};

// Reads the state metrics from their sources at scrape time (see metrics.h). A source that
// fails is left out of that scrape and logged; the other families are still served.
class Metrics::StateCollector : public prometheus::Collectable {
 public:
  StateCollector(MetricsSources sources, std::shared_ptr<SlamSessionStats> slam_stats)
      : sources_(std::move(sources)), slam_stats_(std::move(slam_stats)) {}

  std::vector<prometheus::MetricFamily> Collect() const override {
    std::vector<prometheus::MetricFamily> families;
    if (sources_.slam != nullptr) CollectSlam(families);
    if (sources_.crossings != nullptr) CollectCrossings(families);
    if (!sources_.database_path.empty()) CollectDatabase(families);
    return families;
  }

 private:
  void CollectSlam(std::vector<prometheus::MetricFamily>& families) const {
    absl::StatusOr<v1::ListSessionsResponse> sessions = sources_.slam->ListSessions("");
    if (!sessions.ok()) {
      spdlog::warn("metrics: cannot list SLAM sessions: {}", sessions.status().ToString());
      return;
    }
    int active = 0;
    uint64_t queued = 0;
    uint32_t max_queued = 0;
    std::set<std::string> resident;
    for (const v1::Session& session : sessions->sessions()) {
      if (!session.resident()) continue;
      ++active;
      queued += session.queued_messages();
      max_queued = std::max(max_queued, session.queued_messages());
      resident.insert(session.session_id());
    }
    CollectSlamSessions(*sessions, slam_stats_->Keep(resident), families);
    families.push_back(
        GaugeFamily("waymark_slam_sessions_active", "SLAM sessions held in this server's memory"));
    AddGauge(families.back(), active);
    families.push_back(GaugeFamily("waymark_slam_queue_depth",
                                   "SLAM messages accepted and waiting, summed over sessions"));
    AddGauge(families.back(), static_cast<double>(queued));
    families.push_back(GaugeFamily("waymark_slam_queue_depth_max",
                                   "SLAM messages waiting in the fullest session queue"));
    AddGauge(families.back(), max_queued);
    families.push_back(GaugeFamily(
        "waymark_slam_queue_capacity",
        "SLAM messages a session queue holds; beyond it messages get RESOURCE_EXHAUSTED"));
    AddGauge(families.back(), sources_.slam->options().queue_capacity);
  }

  // Per session in memory (label `session`, its id): scans processed, messages waiting, loop
  // closures and the processing time of its recent scans (quantile 0.5 and 0.99 of the last
  // SlamSessionStats::kWindow).
  static void CollectSlamSessions(const v1::ListSessionsResponse& sessions,
                                  const std::map<std::string, SlamSessionStats::Entry>& stats,
                                  std::vector<prometheus::MetricFamily>& families) {
    prometheus::MetricFamily scans = GaugeFamily(
        "waymark_slam_session_scans", "Scans (or frames) a SLAM session in memory has processed");
    prometheus::MetricFamily queue = GaugeFamily(
        "waymark_slam_session_queue_depth", "Messages waiting in a SLAM session's input queue");
    prometheus::MetricFamily closures = GaugeFamily(
        "waymark_slam_session_loop_closures",
        "Loop closures of a laser SLAM session, as its last answer counted them");
    prometheus::MetricFamily seconds = GaugeFamily(
        "waymark_slam_session_scan_seconds",
        "Processing time of a SLAM session's recent scans (the last 256), by quantile");
    for (const v1::Session& session : sessions.sessions()) {
      if (!session.resident()) continue;
      const std::string& id = session.session_id();
      AddGauge(scans, static_cast<double>(session.scans_processed()), {{"session", id}});
      AddGauge(queue, session.queued_messages(), {{"session", id}});
      auto it = stats.find(id);
      if (it == stats.end()) continue;  // nothing processed since it was loaded
      AddGauge(closures, static_cast<double>(it->second.loop_closures), {{"session", id}});
      if (it->second.recent_seconds.empty()) continue;
      for (const auto& [label, q] : {std::pair<const char*, double>{"0.5", 0.5}, {"0.99", 0.99}}) {
        AddGauge(seconds, Quantile(it->second.recent_seconds, q),
                 {{"quantile", label}, {"session", id}});
      }
    }
    for (prometheus::MetricFamily* family : {&scans, &queue, &closures, &seconds}) {
      families.push_back(std::move(*family));
    }
  }

  void CollectCrossings(std::vector<prometheus::MetricFamily>& families) const {
    absl::StatusOr<v1::ListDatabasesResponse> databases = sources_.crossings->ListDatabases();
    if (!databases.ok()) {
      spdlog::warn("metrics: cannot list crossing databases: {}", databases.status().ToString());
      return;
    }
    families.push_back(
        GaugeFamily("waymark_crossing_views", "Views enrolled in a crossing database"));
    for (const v1::CrossingDatabase& db : databases->databases()) {
      AddGauge(families.back(), db.views(), {{"database", db.name()}});
    }
  }

  void CollectDatabase(std::vector<prometheus::MetricFamily>& families) const {
    const std::string& path = sources_.database_path;
    families.push_back(GaugeFamily("waymark_database_bytes",
                                   "Size of the SQLite database file plus its write-ahead log"));
    AddGauge(families.back(), static_cast<double>(FileBytes(path) + FileBytes(path + "-wal")));
  }

  const MetricsSources sources_;
  const std::shared_ptr<SlamSessionStats> slam_stats_;
};

Metrics::Metrics(const MetricsSources& sources)
    : registry_(std::make_shared<prometheus::Registry>()),
      // The SLAM families exist only with a SLAM source (a page without one has none).
      slam_stats_(sources.slam != nullptr ? std::make_shared<SlamSessionStats>(*registry_)
                                          : nullptr),
      state_(std::make_shared<StateCollector>(sources, slam_stats_)),
      slam_(sources.slam),
      requests_(&prometheus::BuildCounter()
                     .Name("waymark_rpc_requests_total")
                     .Help("RPCs finished, by full method name and status code")
                     .Register(*registry_)),
      latency_(&prometheus::BuildHistogram()
                    .Name("waymark_rpc_latency_seconds")
                    .Help("Time from a call's arrival to its status, by method (streams: the "
                          "stream's duration)")
                    .Register(*registry_)),
      in_flight_(&prometheus::BuildGauge()
                      .Name("waymark_rpc_in_flight")
                      .Help("RPCs started and not yet finished, by method")
                      .Register(*registry_)),
      recognitions_(&prometheus::BuildCounter()
                         .Name("waymark_recognitions_total")
                         .Help("Recognition answers (unary calls and stream frames), by outcome")
                         .Register(*registry_)) {
  if (slam_ != nullptr) {
    // The observer holds the stats (and through them the registry's families), not this: a
    // worker may still be in it while ~Metrics runs.
    std::shared_ptr<SlamSessionStats> stats = slam_stats_;
    std::shared_ptr<prometheus::Registry> registry = registry_;
    slam_->SetUpdateObserver(
        [stats, registry](const std::string& session_id, const v1::SlamUpdate& update) {
          stats->Observe(session_id, update);
        });
    SlamObserver released;
    released.on_released = [stats](const std::string& session_id) { stats->Forget(session_id); };
    slam_observer_ = slam_->AddObserver(std::move(released));
  }
}

Metrics::~Metrics() {
  if (slam_ != nullptr) {
    slam_->SetUpdateObserver(nullptr);
    slam_->RemoveObserver(slam_observer_);
  }
  // Stop serving before the families and the collector go away.
  StopExposer(std::move(exposer_), host_, port());
}

void Metrics::RpcStarted(const std::string& method) {
  in_flight_->Add({{"method", method}}).Increment();
}

void Metrics::RpcFinished(const std::string& method, grpc::StatusCode code, double seconds) {
  in_flight_->Add({{"method", method}}).Decrement();
  requests_->Add({{"method", method}, {"code", StatusCodeName(code)}}).Increment();
  latency_->Add({{"method", method}}, LatencyBuckets()).Observe(seconds);
}

void Metrics::RecordRecognition(const v1::RecognizeResponse& response) {
  const char* outcome = "unknown";
  if (response.error_code() != 0) {
    outcome = "error";
  } else if (response.recognized()) {
    outcome = "recognized";
  } else if (response.keypoints() == 0) {
    outcome = "no_features";
  }
  recognitions_->Add({{"outcome", outcome}}).Increment();
}

void Metrics::RecordRecognitionError() { recognitions_->Add({{"outcome", "error"}}).Increment(); }

std::string Metrics::Render() const {
  std::vector<prometheus::MetricFamily> families = registry_->Collect();
  std::vector<prometheus::MetricFamily> state = state_->Collect();
  families.insert(families.end(), std::make_move_iterator(state.begin()),
                  std::make_move_iterator(state.end()));
  return prometheus::TextSerializer().Serialize(families);
}

size_t Metrics::slam_sessions_tracked() const {
  return slam_stats_ != nullptr ? slam_stats_->size() : 0;
}

int Metrics::port() const {
  if (exposer_ == nullptr) return 0;
  const std::vector<int> ports = exposer_->GetListeningPorts();
  return ports.empty() ? 0 : ports.front();
}

absl::StatusOr<std::unique_ptr<Metrics>> StartMetrics(const std::string& listen,
                                                      const MetricsSources& sources) {
  if (absl::Status s = CheckListen(listen); !s.ok()) return s;
  auto metrics = std::make_unique<Metrics>(sources);
  try {
    // civetweb reports a failed bind as an exception from the constructor.
    // civetweb's threads get at least this much stack (thread_stack_floor.cc says why).
    static_assert(kThreadStackFloor >= (1 << 20));
    (void)ThreadStackFloor();
    metrics->exposer_ = std::make_unique<prometheus::Exposer>(listen, /*num_threads=*/2);
  } catch (const std::exception& e) {
    return absl::UnavailableError(
        absl::StrCat("cannot serve metrics on ", listen, " (address in use?): ", e.what()));
  }
  metrics->host_ = listen.substr(0, listen.rfind(':'));
  metrics->exposer_->RegisterCollectable(metrics->registry_);
  metrics->exposer_->RegisterCollectable(metrics->state_);
  spdlog::info("metrics at http://{}:{}/metrics", metrics->host_, metrics->port());
  return metrics;
}

}  // namespace waymark::service
