#ifndef WAYMARK_CLIENT_LIB_RETRY_H_
#define WAYMARK_CLIENT_LIB_RETRY_H_

#include "absl/status/status.h"
#include "absl/time/time.h"

namespace waymark::client {

// Exponential backoff for idempotent reads that fail with UNAVAILABLE (a Wi-Fi drop, a server
// restart). Writes are never retried: the first attempt may have been applied.
struct RetryOptions {
  int max_attempts = 4;  // including the first; 1 disables retries
  absl::Duration initial_backoff = absl::Milliseconds(200);
  double backoff_multiplier = 2.0;
  absl::Duration max_backoff = absl::Seconds(5);
  // Each delay is scaled by a random factor in [1 - jitter, 1 + jitter], so a fleet of robots that
  // lost the server together does not reconnect in lockstep.
  double jitter = 0.2;
};

// Delay before retry number `retry` (1 = the first retry), without jitter:
// initial_backoff * multiplier^(retry - 1), capped at max_backoff.
absl::Duration BackoffDelay(const RetryOptions& options, int retry);

// `delay` scaled by a random factor in [1 - jitter, 1 + jitter] (jitter clamped to [0, 1]).
absl::Duration Jitter(absl::Duration delay, double jitter);

// Only UNAVAILABLE is transient by contract; every other code is the server's answer.
bool IsRetryable(const absl::Status& status);

}  // namespace waymark::client

#endif  // WAYMARK_CLIENT_LIB_RETRY_H_
