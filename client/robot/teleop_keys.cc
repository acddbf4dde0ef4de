#include "client/robot/teleop_keys.h"

#include <algorithm>
#include <cctype>

namespace waymark::cli {

TeleopAction ApplyTeleopKey(char key, TeleopTarget& target, const VelocityLimits& limits,
                            const TeleopSteps& steps) {
  auto step = [](double value, double delta, double limit) {
    const double next = std::clamp(value + delta, -limit, limit);
    return std::abs(next) < 1e-9 ? 0.0 : next;  // no -0.0 or rounding crumbs on the way to 0
  };
  switch (std::tolower(static_cast<unsigned char>(key))) {
    case 'w':
      target.linear = step(target.linear, steps.linear, limits.max_linear);
      break;
    case 's':
      target.linear = step(target.linear, -steps.linear, limits.max_linear);
      break;
    case 'a':
      target.angular = step(target.angular, steps.angular, limits.max_angular);
      break;
    case 'd':
      target.angular = step(target.angular, -steps.angular, limits.max_angular);
      break;
    case ' ':
    case 'x':
      target = {};
      return TeleopAction::kStop;
    case 'c':
      return TeleopAction::kRecognize;
    case 'q':
      return TeleopAction::kQuit;
    default:
      return TeleopAction::kNone;
  }
  return TeleopAction::kDrive;
}

const char* TeleopHelp() {
  return "teleop: w/s faster/slower, a/d turn left/right, space stop, c recognize crossing, "
         "q quit";
}

}  // namespace waymark::cli
