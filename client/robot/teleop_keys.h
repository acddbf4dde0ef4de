#ifndef WAYMARK_CLIENT_ROBOT_TELEOP_KEYS_H_
#define WAYMARK_CLIENT_ROBOT_TELEOP_KEYS_H_

// The keyboard of `waymark robot`. In every mode q quits (as Ctrl-C does) and c recognizes the
// crossing now. In teleop mode the keys also drive: w/s speed up / slow down (backwards below
// zero), a/d turn left / right, space or x stops. Each key changes the target by one step;
// targets stay within the limits.

#include <atomic>
#include <functional>
#include <string>

#include "absl/status/status.h"
#include "client/robot/safety_guard.h"  // VelocityLimits

namespace waymark::cli {

enum class TeleopAction { kNone, kDrive, kStop, kRecognize, kQuit };

struct TeleopTarget {
  double linear = 0;
  double angular = 0;
};

struct TeleopSteps {
  double linear = 0.05;  // m/s per key press
  double angular = 0.1;  // rad/s per key press
};

// Applies one key to `target` (teleop mode). Unknown keys are kNone and leave it unchanged.
TeleopAction ApplyTeleopKey(char key, TeleopTarget& target, const VelocityLimits& limits,
                            const TeleopSteps& steps = {});

// One key in any mode: teleop as ApplyTeleopKey; otherwise only q (kQuit) and c (kRecognize)
// mean something, and the driving keys are kNone (the server drives, or nobody).
TeleopAction ApplyKey(char key, bool teleop, TeleopTarget& target, const VelocityLimits& limits,
                      const TeleopSteps& steps = {});

// The help line printed when the run starts (teleop: every key; otherwise q and c).
const char* TeleopHelp();
const char* KeysHelp(bool teleop);

// What the keys do to the run.
struct KeyboardHooks {
  std::function<void()> quit;       // q: stop the run as Ctrl-C does
  std::function<void()> recognize;  // c; may be null (no camera)
  // Teleop only (null in the other modes): drive (linear, angular). The target is re-sent every
  // poll while it is not zero, so each command's short validity keeps a hung keyboard safe.
  std::function<absl::Status(double, double)> drive;
  // Teleop: true when the loop's commanded velocity is zero (a safety stop zeroed it): the
  // target is then dropped so the robot does not drive on into what stopped it.
  std::function<bool()> base_stopped;
  std::function<void(const std::string&)> say;  // notes for the user
};

// Reads keys from `fd` until `stop` is set, q is pressed or the input ends, polling every
// `poll_ms`. The end of input (EOF, a hang-up) in teleop stops the robot at once and says so
// (nobody is steering any more); in the other modes it only ends the reading.
void ReadKeys(int fd, const std::atomic<bool>& stop, const VelocityLimits& limits,
              const KeyboardHooks& hooks, int poll_ms = 150);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_ROBOT_TELEOP_KEYS_H_
