"""One unary call with one deadline over all its attempts; reads are retried on UNAVAILABLE with
exponential backoff and jitter, writes are sent once (the first attempt may have been applied).
The policy of the C++ client (client/lib/retry.h, client/lib/unary_call.h)."""
import dataclasses
import random
import time

import grpc

from waymark.errors import from_rpc_error


@dataclasses.dataclass(frozen=True)
class RetryOptions:
    max_attempts: int = 4          # including the first; 1 disables retries
    initial_backoff: float = 0.2   # seconds
    backoff_multiplier: float = 2.0
    max_backoff: float = 5.0       # seconds
    # Each delay is scaled by a random factor in [1 - jitter, 1 + jitter], so a fleet of robots
    # that lost the server together does not reconnect in lockstep.
    jitter: float = 0.2

    def delay(self, retry):
        """Seconds before retry number `retry` (1 = the first), jitter included."""
        base = min(self.max_backoff, self.initial_backoff * self.backoff_multiplier ** (retry - 1))
        jitter = min(1.0, max(0.0, self.jitter))
        return base * random.uniform(1.0 - jitter, 1.0 + jitter)


def call_unary(method, request, timeout, retry, read):
    """`method(request, timeout=...)` of a stub; raises waymark.Error. `timeout` (seconds, None =
    none) bounds the whole call, retries and backoff included."""
    deadline = None if timeout is None else time.monotonic() + timeout
    attempts = max(1, retry.max_attempts) if read else 1
    attempt = 1
    while True:
        remaining = None if deadline is None else max(0.0, deadline - time.monotonic())
        try:
            return method(request, timeout=remaining)
        except grpc.RpcError as e:
            error = from_rpc_error(e)
        if attempt >= attempts or error.code != grpc.StatusCode.UNAVAILABLE:
            raise error
        delay = retry.delay(attempt)
        if deadline is not None and time.monotonic() + delay >= deadline:
            raise error  # no time left for another attempt: report the real cause
        time.sleep(delay)
        attempt += 1
