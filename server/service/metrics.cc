#include "server/service/metrics.h"

#include "server/service/thread_stack_floor.h"

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

// Reads the state metrics from their sources at scrape time (see metrics.h). A source that
// fails is left out of that scrape and logged; the other families are still served.
class Metrics::StateCollector : public prometheus::Collectable {
 public:
  explicit StateCollector(MetricsSources sources) : sources_(std::move(sources)) {}

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
    for (const v1::Session& session : sessions->sessions()) {
      if (!session.resident()) continue;
      ++active;
      queued += session.queued_messages();
      max_queued = std::max(max_queued, session.queued_messages());
    }
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
};

Metrics::Metrics(const MetricsSources& sources)
    : registry_(std::make_shared<prometheus::Registry>()),
      state_(std::make_shared<StateCollector>(sources)),
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
                         .Register(*registry_)) {}

Metrics::~Metrics() {
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
