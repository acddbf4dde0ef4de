#ifndef WAYMARK_SERVER_COMMON_STOPWATCH_H_
#define WAYMARK_SERVER_COMMON_STOPWATCH_H_

// Shared by the engines and the service. Stage timings reported to robots (StageTimings) are wall-clock milliseconds on a monotonic clock.

#include <chrono>

namespace waymark {

using Clock = std::chrono::steady_clock;

inline double MsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

}  // namespace waymark

#endif  // WAYMARK_SERVER_COMMON_STOPWATCH_H_
