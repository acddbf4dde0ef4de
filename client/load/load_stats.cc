#include "client/load/load_stats.h"

#include <algorithm>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "client/eval/eval_metrics.h"  // Percentile
#include "client/common/output.h"

namespace waymark::cli {

void LoadRecorder::Sent(const std::string& rpc, int64_t count) {
  std::lock_guard<std::mutex> lock(mutex_);
  rpcs_[rpc].calls += count;
}

void LoadRecorder::Answered(const std::string& rpc, double latency_ms) {
  std::lock_guard<std::mutex> lock(mutex_);
  rpcs_[rpc].latencies_ms.push_back(latency_ms);
}

void LoadRecorder::Failed(const std::string& rpc, absl::StatusCode code) {
  std::lock_guard<std::mutex> lock(mutex_);
  Rpc& entry = rpcs_[rpc];
  ++entry.failed;
  ++entry.errors[code];
}

LoadTotals LoadRecorder::Totals() const {
  std::lock_guard<std::mutex> lock(mutex_);
  LoadTotals totals;
  for (const auto& [name, rpc] : rpcs_) {
    totals.calls += rpc.calls;
    totals.failed += rpc.failed;
  }
  return totals;
}

std::map<std::string, RpcSummary> LoadRecorder::Summarize(double elapsed_s) const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::map<std::string, RpcSummary> out;
  for (const auto& [name, rpc] : rpcs_) {
    RpcSummary& s = out[name];
    s.calls = rpc.calls;
    s.answered = static_cast<int64_t>(rpc.latencies_ms.size());
    s.failed = rpc.failed;
    s.per_second = elapsed_s > 0 ? rpc.calls / elapsed_s : 0;
    s.p50_ms = Percentile(rpc.latencies_ms, 50);
    s.p99_ms = Percentile(rpc.latencies_ms, 99);
    if (!rpc.latencies_ms.empty()) {
      s.max_ms = *std::max_element(rpc.latencies_ms.begin(), rpc.latencies_ms.end());
    }
    for (const auto& [code, count] : rpc.errors) s.errors[absl::StatusCodeToString(code)] = count;
  }
  return out;
}

std::map<std::string, int64_t> ErrorsByCode(const std::map<std::string, RpcSummary>& rpcs) {
  std::map<std::string, int64_t> errors;
  for (const auto& [name, rpc] : rpcs) {
    for (const auto& [code, count] : rpc.errors) errors[code] += count;
  }
  return errors;
}

nlohmann::json RpcSummariesJson(const std::map<std::string, RpcSummary>& rpcs) {
  nlohmann::json out = nlohmann::json::object();
  for (const auto& [name, s] : rpcs) {
    out[name] = {{"calls", s.calls},
                 {"answered", s.answered},
                 {"failed", s.failed},
                 {"per_s", s.per_second},
                 {"latency_ms",
                  {{"p50", OptionalJson(s.p50_ms)},
                   {"p99", OptionalJson(s.p99_ms)},
                   {"max", OptionalJson(s.max_ms)}}},
                 {"errors", s.errors}};
  }
  return out;
}

void PrintRpcTable(std::ostream& out, const std::map<std::string, RpcSummary>& rpcs) {
  Table table({{"RPC"},
               {"CALLS", true},
               {"PER S", true},
               {"ANSWERED", true},
               {"P50 MS", true},
               {"P99 MS", true},
               {"MAX MS", true},
               {"ERRORS"}});
  for (const auto& [name, s] : rpcs) {
    std::vector<std::string> errors;
    for (const auto& [code, count] : s.errors) errors.push_back(absl::StrCat(code, " ", count));
    table.AddRow({name, absl::StrCat(s.calls), FormatNumber(s.per_second, 1),
                  absl::StrCat(s.answered), FormatNumber(s.p50_ms, 1), FormatNumber(s.p99_ms, 1),
                  FormatNumber(s.max_ms, 1), errors.empty() ? "-" : absl::StrJoin(errors, ", ")});
  }
  table.Print(out);
}

}  // namespace waymark::cli
