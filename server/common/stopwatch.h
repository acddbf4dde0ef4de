#ifndef WAYMARK_SERVER_COMMON_STOPWATCH_H_
#define WAYMARK_SERVER_COMMON_STOPWATCH_H_

// Shared by the engines and the service. Stage timings reported to robots (StageTimings) are wall-clock milliseconds on a monotonic clock.

#include <chrono>

namespace waymark {

using Clock = std::chrono::steady_clock;

inline double MsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

// Seconds on the monotonic clock: for leases and periods (a wall-clock jump must not end one).
inline double SteadySeconds() {
  return std::chrono::duration<double>(Clock::now().time_since_epoch()).count();
}

}  // namespace waymark

#endif  // WAYMARK_SERVER_COMMON_STOPWATCH_H_
