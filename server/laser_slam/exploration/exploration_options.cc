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
      {o.lookahead, "lookahead"},           {o.exit_growth, "exit_growth"},
      {o.grid_resolution, "grid_resolution"}, {o.approach_radius, "approach_radius"},
      {o.arrive_radius, "arrive_radius"},   {o.face_tolerance, "face_tolerance"},
      {o.path_lookahead, "path_lookahead"}, {o.comfort_distance, "comfort_distance"},
      {o.gain_floor, "gain_floor"},         {o.wall_explained, "wall_explained"},
      {o.wall_view_min, "wall_view_min"},   {o.wall_view_max, "wall_view_max"}};
  for (const auto& [value, name] : positive) {
    if (absl::Status s = Positive(value, absl::StrCat("exploration ", name)); !s.ok()) return s;
  }
  const std::initializer_list<std::pair<double, const char*>> non_negative = {
      {o.clearance, "clearance"},           {o.weight_uncertainty, "weight_uncertainty"},
      {o.weight_extension, "weight_extension"}, {o.weight_endpoints, "weight_endpoints"},
      {o.min_extension, "min_extension"},   {o.corner_reach, "corner_reach"},
      {o.corner_angle, "corner_angle"},     {o.wall_penalty, "wall_penalty"},
      {o.progress_slack, "progress_slack"}, {o.weight_gain, "weight_gain"},
      {o.travel_cost, "travel_cost"},       {o.weight_trip_uncertainty, "weight_trip_uncertainty"},
      {o.revisit_variance, "revisit_variance"}, {o.revisit_travel, "revisit_travel"},
      {o.switch_margin, "switch_margin"}};
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
  if (o.grid_resolution < 0.02 || o.grid_resolution > 0.5) {
    return absl::InvalidArgumentError(absl::StrCat(
        "exploration grid_resolution must be in [0.02, 0.5] m, got ", o.grid_resolution));
  }
  if (o.wall_view_min >= o.wall_view_max) {
    return absl::InvalidArgumentError("exploration wall_view_min must be below wall_view_max");
  }
  if (o.min_frontier_cells < 1 || o.no_progress_decisions < 1 || o.done_decisions < 1 ||
      o.stuck_decisions < 1) {
    return absl::InvalidArgumentError(
        "min_frontier_cells, no_progress_decisions, done_decisions and stuck_decisions must be "
        ">= 1");
  }
  return absl::OkStatus();
}

}  // namespace waymark::laser_slam
