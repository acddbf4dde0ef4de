#include "client/lib/retry.h"

#include <algorithm>
#include <random>

namespace waymark::client {

absl::Duration BackoffDelay(const RetryOptions& options, int retry) {
  absl::Duration delay = options.initial_backoff;
  for (int i = 1; i < retry && delay < options.max_backoff; ++i) {
    delay *= options.backoff_multiplier;
  }
  return std::min(delay, options.max_backoff);
}

absl::Duration Jitter(absl::Duration delay, double jitter) {
  jitter = std::clamp(jitter, 0.0, 1.0);
  if (jitter == 0.0) return delay;
  thread_local std::mt19937 rng{std::random_device{}()};
  std::uniform_real_distribution<double> factor(1.0 - jitter, 1.0 + jitter);
  return delay * factor(rng);
}

bool IsRetryable(const absl::Status& status) {
  return status.code() == absl::StatusCode::kUnavailable;
}

}  // namespace waymark::client
