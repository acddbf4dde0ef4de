#ifndef WAYMARK_CLIENT_LIB_UNARY_CALL_H_
#define WAYMARK_CLIENT_LIB_UNARY_CALL_H_

// One unary call with a deadline over all attempts and retries for reads: the policy every
// service client uses (CrossingClient, SlamClient).

#include <grpcpp/grpcpp.h>

#include <algorithm>
#include <chrono>
#include <thread>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "client/lib/crossing_client.h"  // DeadlineAfter
#include "client/lib/retry.h"
#include "client/lib/status_util.h"

namespace waymark::client {

// Reads are retried on transient errors; writes are sent once (a retry could apply them twice).
enum class Idempotency { kRead, kWrite };

// `invoke(grpc::ClientContext*, Response*)` makes the call and returns its grpc::Status. One
// deadline covers all attempts, so `timeout` bounds what the user waits, retries included.
template <typename Response, typename Invoke>
absl::StatusOr<Response> CallUnary(absl::Duration timeout, const RetryOptions& retry,
                                   Idempotency idempotency, Invoke invoke) {
  const Deadline deadline = DeadlineAfter(timeout);
  const int max_attempts = idempotency == Idempotency::kRead ? std::max(1, retry.max_attempts) : 1;
  for (int attempt = 1;; ++attempt) {
    grpc::ClientContext context;
    if (deadline.has_value()) context.set_deadline(*deadline);
    Response response;
    absl::Status status = ToAbslStatus(invoke(&context, &response));
    if (status.ok()) return response;
    if (attempt >= max_attempts || !IsRetryable(status)) return status;
    const auto delay =
        absl::ToChronoNanoseconds(Jitter(BackoffDelay(retry, attempt), retry.jitter));
    if (deadline.has_value() && std::chrono::system_clock::now() + delay >= *deadline) {
      return status;  // no time left for another attempt; report the real cause
    }
    std::this_thread::sleep_for(delay);
  }
}

}  // namespace waymark::client

#endif  // WAYMARK_CLIENT_LIB_UNARY_CALL_H_
