#ifndef WAYMARK_TESTS_ROBOT_EVENTUALLY_H_
#define WAYMARK_TESTS_ROBOT_EVENTUALLY_H_

// Polls a condition until it holds or the time runs out: how the device tests wait for threads
// (drivers, fake peers) without asserting on wall-clock time. The default timeout is generous:
// it only turns a hang into a failure, and a loaded machine may take seconds for what a quiet one
// does in milliseconds.

#include <functional>

#include "absl/time/clock.h"
#include "absl/time/time.h"

namespace waymark::testing {

inline bool Eventually(const std::function<bool()>& condition,
                       absl::Duration timeout = absl::Seconds(60)) {
  const absl::Time deadline = absl::Now() + timeout;
  while (absl::Now() < deadline) {
    if (condition()) return true;
    absl::SleepFor(absl::Milliseconds(10));
  }
  return condition();
}

}  // namespace waymark::testing

#endif  // WAYMARK_TESTS_ROBOT_EVENTUALLY_H_
