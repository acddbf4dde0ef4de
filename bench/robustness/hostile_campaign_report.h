#ifndef WAYMARK_BENCH_ROBUSTNESS_HOSTILE_CAMPAIGN_REPORT_H_
#define WAYMARK_BENCH_ROBUSTNESS_HOSTILE_CAMPAIGN_REPORT_H_

// waymark-hostile-campaign: what is counted per RPC, the inputs kept as evidence, and the
// summary table.

#include <cstdint>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "bench/robustness/hostile_campaign_calls.h"

namespace waymark::bench::hostile {

// One RPC's (or one auth case's) calls.
class RpcStats {
 public:
  // `rejections`: codes of per-message rejections in the answers of a stream.
  void Record(const CallInput& input, const CallOutcome& outcome,
              const std::vector<std::string>& anomalies, const std::vector<int>& rejections = {});
  void Merge(const RpcStats& other);

  int64_t calls() const { return calls_; }
  int64_t malformed() const { return malformed_; }
  int64_t deadline_exceeded() const;
  const std::map<std::string, int64_t>& codes() const { return codes_; }
  const std::map<std::string, int64_t>& anomalies() const { return anomalies_; }
  double QuantileMs(double q) const;
  // "OK 120, INVALID_ARGUMENT 9880", most frequent first.
  std::string CodesSummary() const;
  nlohmann::json ToJson() const;

 private:
  int64_t calls_ = 0;
  int64_t messages_ = 0;     // messages written
  int64_t malformed_ = 0;    // ... of which mutated
  int64_t unparsable_ = 0;   // ... of which do not parse as the request type
  int64_t write_refused_ = 0;  // calls in which the server ended the call before a write
  int64_t answers_ = 0;
  std::map<std::string, int64_t> codes_;
  std::map<std::string, int64_t> rejection_codes_;  // inside answers (streams that go on)
  std::map<std::string, std::map<std::string, int64_t>> codes_by_shape_;
  // Per operator: the codes of the calls that sent a message it made (a call counts once per
  // operator it used).
  std::map<std::string, std::map<std::string, int64_t>> codes_by_operator_;
  std::map<std::string, int64_t> anomalies_;
  // A few distinct status messages per code, to tell what the server said.
  std::map<std::string, std::vector<std::string>> messages_by_code_;
  std::vector<double> latencies_ms_;
};

// Inputs that made the server misbehave, kept under DIR/samples/<rpc>/<anomaly>-<n>.json (the
// call, its outcome) with the first malformed message also as a raw .bin: a bounded number per
// RPC and anomaly, so a campaign of a million calls leaves a readable folder.
class SampleSaver {
 public:
  SampleSaver(std::string dir, int per_kind) : dir_(std::move(dir)), per_kind_(per_kind) {}
  // The path written, or "" when enough of this kind are kept already.
  std::string Save(const std::string& rpc, const std::string& anomaly, const CallInput& input,
                   const CallOutcome& outcome);
  nlohmann::json Index() const;  // rpc -> anomaly -> paths

 private:
  std::string dir_;
  int per_kind_;
  mutable std::mutex mutex_;
  std::map<std::string, std::map<std::string, std::vector<std::string>>> saved_;
};

// Writes `input` (and the outcome, when given) as JSON to `path`, plus `path`.bin holding the
// first malformed message's bytes.
void WriteCallFile(const std::string& path, const CallInput& input, const CallOutcome* outcome,
                   const nlohmann::json& extra = {});

// The campaign's table: one row per RPC.
void PrintTable(const std::vector<std::pair<std::string, RpcStats>>& rows, std::FILE* out);

// A file name from an RPC name ("CrossingService/EnrollView" -> "CrossingService.EnrollView").
std::string FileSafe(const std::string& name);

}  // namespace waymark::bench::hostile

#endif  // WAYMARK_BENCH_ROBUSTNESS_HOSTILE_CAMPAIGN_REPORT_H_
