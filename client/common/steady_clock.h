#ifndef WAYMARK_CLIENT_COMMON_STEADY_CLOCK_H_
#define WAYMARK_CLIENT_COMMON_STEADY_CLOCK_H_

// Seconds on the monotonic clock: what the robot side measures holds, timeouts and periods with
// (a wall-clock jump must not end a hold early or keep a watchdog from firing).

#include <chrono>

namespace waymark::adapters {

inline double SteadySeconds() {
  return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch()).count();
}

}  // namespace waymark::adapters

#endif  // WAYMARK_CLIENT_COMMON_STEADY_CLOCK_H_
