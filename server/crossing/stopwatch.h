#ifndef WAYMARK_SERVER_CROSSING_STOPWATCH_H_
#define WAYMARK_SERVER_CROSSING_STOPWATCH_H_

// Stage timings reported to robots (StageTimings) are wall-clock milliseconds on a monotonic clock.

#include <chrono>

namespace waymark::crossing {

using Clock = std::chrono::steady_clock;

inline double MsSince(Clock::time_point start) {
  return std::chrono::duration<double, std::milli>(Clock::now() - start).count();
}

}  // namespace waymark::crossing

#endif  // WAYMARK_SERVER_CROSSING_STOPWATCH_H_
