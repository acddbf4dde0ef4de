#ifndef WAYMARK_SERVER_LASER_SLAM_OPTION_CHECKS_H_
#define WAYMARK_SERVER_LASER_SLAM_OPTION_CHECKS_H_

// The range checks the engine's option validators share; messages name the option and the value.

#include <cmath>
#include <string>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"

namespace waymark::laser_slam {

inline absl::Status Positive(double value, const std::string& name) {
  if (!std::isfinite(value) || value <= 0.0) {
    return absl::InvalidArgumentError(absl::StrCat(name, " must be a positive number, got ", value));
  }
  return absl::OkStatus();
}

inline absl::Status NonNegative(double value, const std::string& name) {
  if (!std::isfinite(value) || value < 0.0) {
    return absl::InvalidArgumentError(absl::StrCat(name, " must be >= 0, got ", value));
  }
  return absl::OkStatus();
}

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_OPTION_CHECKS_H_
