#ifndef WAYMARK_BENCH_ROBUSTNESS_HOSTILE_CAMPAIGN_AUTH_H_
#define WAYMARK_BENCH_ROBUSTNESS_HOSTILE_CAMPAIGN_AUTH_H_

// waymark-hostile-campaign, second phase: the authentication surface of a server started as
// deployed (auth on), its tokens made with the server binary's `token create`. Valid requests of
// every RPC are sent with no token, garbage tokens, oversized metadata, a revoked token (used
// while it was valid, so the server had it cached), an expired token, and a robot's token on the
// admin-only RPCs; the codes are recorded per case and RPC.

#include <nlohmann/json.hpp>
#include <string>
#include <utility>
#include <vector>

#include "bench/robustness/hostile_campaign_report.h"
#include "bench/robustness/hostile_campaign_runner.h"

namespace waymark::bench::hostile {

struct AuthOptions {
  int64_t requests_per_case = 2000;
  RunnerOptions runner;  // runner.out is the campaign's --out
};

// Runs the phase on a server of its own (a fresh SQLite file under out/work); fills `rows` (one
// per case) for the table and returns the phase's JSON.
nlohmann::json RunAuthPhase(const AuthOptions& options, SampleSaver* samples,
                            std::vector<std::pair<std::string, RpcStats>>* rows);

}  // namespace waymark::bench::hostile

#endif  // WAYMARK_BENCH_ROBUSTNESS_HOSTILE_CAMPAIGN_AUTH_H_
