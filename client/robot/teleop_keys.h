#ifndef WAYMARK_CLIENT_ROBOT_TELEOP_KEYS_H_
#define WAYMARK_CLIENT_ROBOT_TELEOP_KEYS_H_

// Keyboard teleoperation for `waymark robot --mode teleop`: w/s speed up / slow down (backwards
// below zero), a/d turn left / right, space or x stops, c recognizes the crossing now, q quits.
// Each key changes the target by one step; targets stay within the limits.

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

// Applies one key to `target`. Unknown keys are kNone and leave it unchanged.
TeleopAction ApplyTeleopKey(char key, TeleopTarget& target, const VelocityLimits& limits,
                            const TeleopSteps& steps = {});

// The help line printed when teleop starts.
const char* TeleopHelp();

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_ROBOT_TELEOP_KEYS_H_
