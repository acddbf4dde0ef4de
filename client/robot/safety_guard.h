#ifndef WAYMARK_CLIENT_ROBOT_SAFETY_GUARD_H_
#define WAYMARK_CLIENT_ROBOT_SAFETY_GUARD_H_

// The only path from the robot loop to the base's motors. Every command is clamped to the
// configured limits and carries a validity: a watchdog thread stops the base when a command
// outlives it, so a loop that blocks (a hung server, a stuck device read) cannot leave the robot
// driving. Stops for safety reasons (stream broken, bumper, stall, device error, shutdown) are
// counted for the status line and the run summary.

#include <array>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <string>
#include <thread>

#include "absl/status/status.h"
#include "client/devices/robot_devices.h"

namespace waymark::cli {

enum class StopReason {
  kCommandExpired,  // the watchdog: a command (suggestion, teleop key) outlived its validity
  kStreamBroken,    // the server stream ended, broke or stopped answering
  kBumper,
  kStall,
  kDeviceError,  // the base or the laser stopped reporting
  kShutdown,     // Ctrl-C, end of the run
  kCount,
};
const char* StopReasonName(StopReason reason);

struct VelocityLimits {
  double max_linear = 0.3;   // m/s
  double max_angular = 0.5;  // rad/s
};

class SafetyGuard {
 public:
  // `time_scale`: device seconds per wall second (1 for a real robot, the simulator's speed).
  // The limits are further capped by the base's own. `grace` (wall clock) is added to every
  // validity: the loop ends a hold itself at its duration, the watchdog is the backstop for a
  // loop that does not, and must not race the loop's own stop.
  SafetyGuard(adapters::MobileBase& base, VelocityLimits limits, double time_scale = 1.0,
              double grace = 0.2);
  ~SafetyGuard();  // stops the base
  SafetyGuard(const SafetyGuard&) = delete;
  SafetyGuard& operator=(const SafetyGuard&) = delete;

  // Drives at (linear, angular), clamped, for at most `valid_for` device seconds. Non-finite
  // values are refused with INVALID_ARGUMENT and the base is stopped.
  absl::Status Drive(double linear, double angular, double valid_for);
  // A normal stop (end of a hold); not counted.
  absl::Status Stop();
  // A safety stop, counted under `reason`.
  absl::Status Halt(StopReason reason);

  bool moving() const;
  double commanded_linear() const;
  double commanded_angular() const;
  std::uint64_t stops(StopReason reason) const;
  const VelocityLimits& limits() const { return limits_; }

 private:
  absl::Status StopLocked();
  void Watch();

  adapters::MobileBase& base_;
  VelocityLimits limits_;
  const double time_scale_;
  const double grace_;
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  bool moving_ = false;
  double linear_ = 0;
  double angular_ = 0;
  std::chrono::steady_clock::time_point deadline_;
  std::array<std::uint64_t, static_cast<int>(StopReason::kCount)> stops_{};
  bool quit_ = false;
  std::thread watchdog_;
};

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_ROBOT_SAFETY_GUARD_H_
