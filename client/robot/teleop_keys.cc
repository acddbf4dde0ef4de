#include "client/robot/teleop_keys.h"

#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>

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

TeleopAction ApplyKey(char key, bool teleop, TeleopTarget& target, const VelocityLimits& limits,
                      const TeleopSteps& steps) {
  if (teleop) return ApplyTeleopKey(key, target, limits, steps);
  switch (std::tolower(static_cast<unsigned char>(key))) {
    case 'c':
      return TeleopAction::kRecognize;
    case 'q':
      return TeleopAction::kQuit;
    default:
      return TeleopAction::kNone;
  }
}

const char* TeleopHelp() {
  return "teleop: w/s faster/slower, a/d turn left/right, space stop, c recognize crossing, "
         "q quit";
}

const char* KeysHelp(bool teleop) {
  return teleop ? TeleopHelp() : "keys: q quit (as Ctrl-C), c recognize crossing";
}

void ReadKeys(int fd, const std::atomic<bool>& stop, const VelocityLimits& limits,
              const KeyboardHooks& hooks, int poll_ms) {
  const bool teleop = static_cast<bool>(hooks.drive);
  auto say = [&](const std::string& line) {
    if (hooks.say) hooks.say(line);
  };
  TeleopTarget target;
  bool driving = false;
  while (!stop.load()) {
    pollfd p{fd, POLLIN, 0};
    char key = 0;
    const int ready = ::poll(&p, 1, poll_ms);
    if (ready < 0 && errno == EINTR) continue;
    ssize_t got = 0;
    if (ready > 0) {
      got = ::read(fd, &key, 1);
      if (got < 0 && (errno == EINTR || errno == EAGAIN)) continue;
    }
    if (ready < 0 || (ready > 0 && got <= 0)) {
      // The input went away (EOF, hang-up): nobody is steering any more.
      if (teleop) {
        say("teleop: no more keyboard input; stopping");
        hooks.drive(0, 0).IgnoreError();
      }
      return;
    }
    if (got == 1) {
      switch (ApplyKey(key, teleop, target, limits)) {
        case TeleopAction::kQuit:
          say("q: stopping");
          if (hooks.quit) hooks.quit();
          return;
        case TeleopAction::kRecognize:
          if (hooks.recognize) hooks.recognize();
          break;
        case TeleopAction::kStop:
        case TeleopAction::kDrive:
          driving = true;
          break;
        case TeleopAction::kNone:
          break;
      }
    } else if (driving && hooks.base_stopped && hooks.base_stopped() &&
               (target.linear != 0 || target.angular != 0)) {
      say("teleop: the base was stopped for safety; target reset");
      target = {};
    }
    if (teleop && driving) {
      absl::Status s = hooks.drive(target.linear, target.angular);
      if (!s.ok()) say("teleop: " + s.ToString());
      driving = target.linear != 0 || target.angular != 0;
    }
  }
}

}  // namespace waymark::cli
