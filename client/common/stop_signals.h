#ifndef WAYMARK_CLIENT_COMMON_STOP_SIGNALS_H_
#define WAYMARK_CLIENT_COMMON_STOP_SIGNALS_H_

// SIGINT/SIGTERM request a clean stop (the robot loop stops the base, finishes the stream and
// closes the session); a second SIGINT exits at once (the Pioneer's own watchdog then stops it
// within ~2 s). SIGUSR1 asks for a crossing recognition now. The previous handlers come back on
// destruction. One instance at a time.

#include <atomic>

namespace waymark::cli {

class StopSignals {
 public:
  StopSignals();
  ~StopSignals();
  StopSignals(const StopSignals&) = delete;
  StopSignals& operator=(const StopSignals&) = delete;

  const std::atomic<bool>& stop_requested() const;
  void RequestStop();
  // True once per SIGUSR1 received.
  bool TakeRecognizeRequest();
};

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_COMMON_STOP_SIGNALS_H_
