#ifndef WAYMARK_BENCH_ROBUSTNESS_HOSTILE_CAMPAIGN_RUNNER_H_
#define WAYMARK_BENCH_ROBUSTNESS_HOSTILE_CAMPAIGN_RUNNER_H_

// waymark-hostile-campaign: a batch of calls sent by a few concurrent client threads (each with
// its own connection, as robots have) until the batch's budget is spent, judged one by one. A
// batch survives the server: when it dies, the calls in flight and each thread's last few are
// saved with the server's log and a copy of its database, the inputs are replayed one at a time
// against copies of that database to find the one that kills it, and the server is started
// again so the batch can go on.

#include <chrono>
#include <cstdint>
#include <functional>
#include <fstream>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "bench/robustness/hostile_campaign_calls.h"
#include "bench/robustness/hostile_campaign_mutations.h"
#include "bench/robustness/hostile_campaign_report.h"
#include "bench/robustness/hostile_campaign_server.h"
#include "bench/robustness/hostile_campaign_targets.h"

namespace waymark::bench::hostile {

// One call to make: what to send, whose it is, what it costs against the batch's budget.
struct PlannedCall {
  CallInput input;
  const RpcTarget* target = nullptr;
  int64_t cost = 1;
};

struct Batch {
  std::string name;
  int64_t budget = 0;
  // The call number `index` (0 for the batch's first) of thread `thread`.
  std::function<PlannedCall(int thread, Rng& rng, int64_t index)> plan;
  // The anomalies of one call's outcome (empty: as expected); `previous` is the outcome of the
  // call before it on the same connection (null for the first).
  std::function<std::vector<std::string>(const PlannedCall&, const CallOutcome&,
                                         const CallOutcome* previous)>
      judge;
};

struct RunnerOptions {
  int threads = 4;
  std::chrono::seconds deadline{30};
  uint64_t seed = 1;
  std::string out;            // crash records go under out/crashes
  bool replay_crashes = true;  // find the input that kills the server (costs a restart each)
  std::string trace;           // if set: one JSON line per call (what was sent, what came back)
};

// A server exit during a batch.
struct CrashRecord {
  std::string batch;
  int exit_code = -1;
  std::string dir;               // inputs, log, database copy
  std::vector<std::string> reproduced_by;  // saved inputs that killed a fresh server on replay
  nlohmann::json ToJson() const;
};

class Runner {
 public:
  Runner(WatchedServer* server, SampleSaver* samples, RunnerOptions options);

  // Runs `batch`; the stats per target name.
  std::map<std::string, RpcStats> Run(const Batch& batch);
  const std::vector<CrashRecord>& crashes() const { return crashes_; }

 private:
  // The last calls of one thread (the one in flight first), for crash records.
  struct Journal;
  void Worker(const Batch& batch, int thread, std::atomic<int64_t>& spent,
              std::atomic<int64_t>& index, std::map<std::string, RpcStats>& stats,
              Journal& journal, int64_t max_calls = -1);
  CrashRecord RecordCrash(const Batch& batch, std::vector<Journal>& journals);
  std::vector<std::string> Replay(const std::string& db_copy, const std::vector<std::string>& inputs);

  void Trace(const Batch& batch, int thread, const CallInput& input, const CallOutcome& outcome);

  WatchedServer* server_;
  SampleSaver* samples_;
  RunnerOptions options_;
  std::vector<CrashRecord> crashes_;
  std::mutex trace_mutex_;
  std::ofstream trace_;
};

// What the answers of one call say, whatever the batch: an answer that is not the method's
// response type, NaN or infinity in one (no number a robot acts on may be non-finite), and the
// codes of per-message rejections inside a stream that goes on (SlamUpdate.rejection,
// RecognizeResponse / EnrollViewResponse.error_code), where a server error is as wrong as in a
// call's status.
struct AnswerReport {
  std::vector<std::string> anomalies;  // "unparsable_answer", "non_finite_answer:<field>", ...
  std::vector<int> rejection_codes;    // google.rpc.Code numbers, one per rejected message
};
AnswerReport InspectAnswers(const RpcTarget& target, const CallOutcome& outcome);

// The call's headers, or its answer's, were over a side's metadata limit: gRPC's transport then
// answers RESOURCE_EXHAUSTED and closes the connection.
bool HeadersOverLimit(const CallOutcome& outcome);
// UNAVAILABLE right after such a call on the same connection: the closed connection, not this
// call's own doing.
bool AfterClosedConnection(const CallOutcome& outcome, const CallOutcome* previous);

}  // namespace waymark::bench::hostile

#endif  // WAYMARK_BENCH_ROBUSTNESS_HOSTILE_CAMPAIGN_RUNNER_H_
