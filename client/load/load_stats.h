#ifndef WAYMARK_CLIENT_LOAD_LOAD_STATS_H_
#define WAYMARK_CLIENT_LOAD_LOAD_STATS_H_

// What `waymark bench load` measures, per RPC: calls, answers with their latency, failures by
// status code. Recorded from every robot thread at once; summarised at the end and, for the
// progress line, while the run goes on.
//
// For a stream the "calls" are the messages sent on it and the latency is the time from sending a
// message to its answer (for StreamSensorData: a scan to its SlamUpdate; odometry is not answered).

#include <cstdint>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <ostream>
#include <string>
#include <vector>

#include "absl/status/status.h"

namespace waymark::cli {

struct RpcSummary {
  int64_t calls = 0;
  int64_t answered = 0;  // answers with a latency sample
  int64_t failed = 0;
  double per_second = 0;  // calls / elapsed
  std::optional<double> p50_ms, p99_ms, max_ms;
  std::map<std::string, int64_t> errors;  // status code name -> count
};

struct LoadTotals {
  int64_t calls = 0;
  int64_t failed = 0;
};

class LoadRecorder {
 public:
  void Sent(const std::string& rpc, int64_t count = 1);
  void Answered(const std::string& rpc, double latency_ms);
  void Failed(const std::string& rpc, absl::StatusCode code);

  // Every RPC so far (cheap: for the progress line).
  LoadTotals Totals() const;
  // Per RPC, in name order; rates over `elapsed_s`.
  std::map<std::string, RpcSummary> Summarize(double elapsed_s) const;

 private:
  struct Rpc {
    int64_t calls = 0;
    int64_t failed = 0;
    std::vector<double> latencies_ms;
    std::map<absl::StatusCode, int64_t> errors;
  };
  mutable std::mutex mutex_;
  std::map<std::string, Rpc> rpcs_;
};

// Failures of every RPC by code name.
std::map<std::string, int64_t> ErrorsByCode(const std::map<std::string, RpcSummary>& rpcs);

// {"RecognizeCrossing": {"calls", "answered", "failed", "per_s", "latency_ms": {"p50", "p99",
// "max"}, "errors": {"RESOURCE_EXHAUSTED": n}}, ...}; latencies null without answers.
nlohmann::json RpcSummariesJson(const std::map<std::string, RpcSummary>& rpcs);
// The same as an aligned text table.
void PrintRpcTable(std::ostream& out, const std::map<std::string, RpcSummary>& rpcs);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_LOAD_LOAD_STATS_H_
