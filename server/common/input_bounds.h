#ifndef WAYMARK_SERVER_COMMON_INPUT_BOUNDS_H_
#define WAYMARK_SERVER_COMMON_INPUT_BOUNDS_H_

// Bounds every engine puts on the numbers it accepts: beyond them a number is a corrupt message,
// not a measurement (issue 21). Each engine adds its own (server/laser_slam/input_bounds.h,
// server/visual_slam/frame_validation.cc).

#include <cmath>

namespace waymark {

// Stamps: seconds, |t| below about 3000 years (Unix time and time since start both fit).
inline constexpr double kMaxAbsStampS = 1e11;

// A finite stamp within kMaxAbsStampS.
inline bool PlausibleStamp(double stamp) {
  return std::isfinite(stamp) && std::abs(stamp) <= kMaxAbsStampS;
}

}  // namespace waymark

#endif  // WAYMARK_SERVER_COMMON_INPUT_BOUNDS_H_
