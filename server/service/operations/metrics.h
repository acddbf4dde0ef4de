#ifndef WAYMARK_SERVER_SERVICE_OPERATIONS_METRICS_H_
#define WAYMARK_SERVER_SERVICE_OPERATIONS_METRICS_H_

// The server's Prometheus metrics (names, labels and meaning: docs/operations.md), served as text
// at http://HOST:PORT/metrics by prometheus-cpp's Exposer.
//
// Two kinds:
//   - event metrics (calls, latency, in-flight calls, recognition outcomes), updated by the call
//     interceptor as calls happen; SLAM scans and their processing time, from the SLAM
//     registry's update observer as each scan (or frame) is answered;
//   - state metrics (SLAM sessions and queues, views per crossing database, database file size),
//     read from their sources when Prometheus scrapes, by a Collectable. Reading at scrape time
//     rather than polling from a thread every few seconds means a scrape never shows stale
//     values, nothing runs when nobody scrapes, and there is no thread to stop; the sources are
//     thread-safe and cheap to list (a lock per database, one SELECT of the session table).

#include <grpcpp/support/status.h>

#include <cstddef>
#include <cstdint>
#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "server/service/crossing/crossing_registry.h"
#include "server/service/operations/folder.h"
#include "server/service/slam/slam_registry.h"
#include "waymark/v1/crossing.pb.h"

namespace prometheus {
class Counter;
class Exposer;
class Gauge;
class Histogram;
class Registry;
template <typename T>
class Family;
}  // namespace prometheus

namespace waymark::service {

// Where the state metrics come from. Each may be null/empty: its metrics are then not exported.
// The sources must outlive the Metrics.
struct MetricsSources {
  CrossingRegistry* crossings = nullptr;  // waymark_crossing_views
  SlamRegistry* slam = nullptr;           // waymark_slam_sessions_active, waymark_slam_queue_*
  std::string database_path;              // waymark_database_bytes (the file + its -wal)
};

class Metrics {
 public:
  // The metrics without an HTTP endpoint (StartMetrics adds one).
  explicit Metrics(const MetricsSources& sources);
  ~Metrics();
  Metrics(const Metrics&) = delete;
  Metrics& operator=(const Metrics&) = delete;

  // A call of `method` (full name, "/package.Service/Method") started / ended.
  void RpcStarted(const std::string& method);
  void RpcFinished(const std::string& method, grpc::StatusCode code, double seconds);

  // One recognition answer: outcome recognized, unknown (no crossing qualified), no_features (the
  // image had no keypoints) or error (the answer carries an error_code).
  void RecordRecognition(const v1::RecognizeResponse& response);
  // A recognition call that failed as a whole (its status is the answer): outcome error.
  void RecordRecognitionError();

  // Everything in Prometheus' text format, as a scrape would return it.
  std::string Render() const;
  // The port the endpoint listens on (0 without one).
  int port() const;
  // Sessions whose recent scan times and loop closures are kept (the per-session metrics): those
  // in memory that have answered a scan; a session's entry goes when it leaves memory.
  size_t slam_sessions_tracked() const;

 private:
  friend absl::StatusOr<std::unique_ptr<Metrics>> StartMetrics(const std::string& listen,
                                                               const MetricsSources& sources);
  class StateCollector;
  class SlamSessionStats;  // per session, while it is in memory (bounded labels)

  std::shared_ptr<prometheus::Registry> registry_;
  std::shared_ptr<SlamSessionStats> slam_stats_;  // shared with the registry's observer
  std::shared_ptr<StateCollector> state_;
  SlamRegistry* slam_ = nullptr;  // whose observers this installed
  uint64_t slam_observer_ = 0;    // SlamRegistry::AddObserver's id (sessions leaving memory)
  prometheus::Family<prometheus::Counter>* requests_;
  prometheus::Family<prometheus::Histogram>* latency_;
  prometheus::Family<prometheus::Gauge>* in_flight_;
  prometheus::Family<prometheus::Counter>* recognitions_;
  std::string host_;                              // the endpoint's address, without the port
  std::unique_ptr<prometheus::Exposer> exposer_;  // stopped first by ~Metrics
};

// The canonical name of a status code ("NOT_FOUND"), as the code label and the log lines show it.
std::string StatusCodeName(grpc::StatusCode code);

// Serves the metrics at http://`listen`/metrics. `listen` is IPV4:PORT (0.0.0.0 for every
// interface; no IPv6: Debian's civetweb lacks it); port 0 picks a free port (see
// Metrics::port()). INVALID_ARGUMENT for a malformed address, UNAVAILABLE when it cannot be bound.
absl::StatusOr<std::unique_ptr<Metrics>> StartMetrics(const std::string& listen,
                                                      const MetricsSources& sources);

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_OPERATIONS_METRICS_H_
