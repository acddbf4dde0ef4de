#ifndef WAYMARK_BENCH_ROBUSTNESS_HOSTILE_CAMPAIGN_SHAPES_H_
#define WAYMARK_BENCH_ROBUSTNESS_HOSTILE_CAMPAIGN_SHAPES_H_

// waymark-hostile-campaign: what one hostile call looks like for each kind of RPC.
//   unary:          one malformed request; now and then two requests, or none at all
//   client / bidi:  one malformed message; valid ones around a malformed one; only malformed
//                   ones; a malformed one and then a cancel mid-stream; a half-close before
//                   anything (or after the opening message); an abandoned stream (cancelled
//                   without reading)
//   server stream:  a malformed request, its first answer, then a cancel (Health.Watch never
//                   ends on its own); a cancel at once; two requests
// The first call of each RPC's batch is the valid request itself, so the report shows that the
// seed is accepted and the malformed variants are refused for what they are.

#include <string>
#include <vector>

#include "bench/robustness/hostile_campaign_runner.h"

namespace waymark::bench::hostile {

PlannedCall PlanHostileCall(const RpcTarget& target, const Mutator& mutator, int thread, Rng& rng,
                            bool seed_call);

// A call of `target` with valid messages only: the seed call, and the auth phase's requests.
CallInput ValidCall(const RpcTarget& target, int thread, Rng& rng);

// The codes a server may answer to hostile input: OK (for input that parses), the client-error
// codes, RESOURCE_EXHAUSTED for what is over a limit, CANCELLED when the client cancelled.
// Everything else is an anomaly: DEADLINE_EXCEEDED (a possible hang), UNKNOWN / INTERNAL /
// DATA_LOSS (a server error for a client's mistake), OK for a message that does not parse, ...
std::vector<std::string> JudgeHostile(const PlannedCall& call, const CallOutcome& outcome,
                                      const CallOutcome* previous);

}  // namespace waymark::bench::hostile

#endif  // WAYMARK_BENCH_ROBUSTNESS_HOSTILE_CAMPAIGN_SHAPES_H_
