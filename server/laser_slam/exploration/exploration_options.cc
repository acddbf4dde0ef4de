#include "server/laser_slam/exploration/exploration_options.h"

#include <cmath>
#include <initializer_list>
#include <utility>

#include "absl/strings/str_cat.h"
#include "server/laser_slam/option_checks.h"

namespace waymark::laser_slam {

absl::Status ValidateExplorationOptions(const ExplorationOptions& o) {
  const std::initializer_list<std::pair<double, const char*>> positive = {
      {o.observation_period, "observation_period"}, {o.control_period, "control_period"},
      {o.max_linear, "max_linear"},         {o.max_angular, "max_angular"},
      {o.robot_radius, "robot_radius"},     {o.zero_floor, "zero_floor"},
      {o.sample_step, "sample_step"},       {o.wall_offset, "wall_offset"},
      {o.switch_distance, "switch_distance"}, {o.adjacency, "adjacency"},
      {o.lookahead, "lookahead"},           {o.exit_growth, "exit_growth"}};
  for (const auto& [value, name] : positive) {
    if (absl::Status s = Positive(value, absl::StrCat("exploration ", name)); !s.ok()) return s;
  }
  const std::initializer_list<std::pair<double, const char*>> non_negative = {
      {o.clearance, "clearance"},           {o.weight_uncertainty, "weight_uncertainty"},
      {o.weight_extension, "weight_extension"}, {o.weight_endpoints, "weight_endpoints"},
      {o.min_extension, "min_extension"},   {o.corner_reach, "corner_reach"},
      {o.corner_angle, "corner_angle"}};
  for (const auto& [value, name] : non_negative) {
    if (absl::Status s = NonNegative(value, absl::StrCat("exploration ", name)); !s.ok()) return s;
  }
  if (o.control_period > o.observation_period) {
    return absl::InvalidArgumentError("control_period must not exceed observation_period");
  }
  if (o.linear_steps < 2 || o.linear_steps > 20 || o.angular_steps < 1 || o.angular_steps > 41 ||
      o.angular_steps % 2 == 0) {
    return absl::InvalidArgumentError(absl::StrCat(
        "linear_steps must be in [2, 20] and angular_steps odd in [1, 41] (so that straight "
        "ahead is a candidate), got ",
        o.linear_steps, " and ", o.angular_steps));
  }
  if (o.trap_decisions < 1 || o.stall_decisions < 1 || o.escape_after < 1) {
    return absl::InvalidArgumentError(
        "trap_decisions, stall_decisions and escape_after must be >= 1");
  }
  return absl::OkStatus();
}

}  // namespace waymark::laser_slam
