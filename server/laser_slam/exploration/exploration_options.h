#ifndef WAYMARK_SERVER_LASER_SLAM_EXPLORATION_EXPLORATION_OPTIONS_H_
#define WAYMARK_SERVER_LASER_SLAM_EXPLORATION_EXPLORATION_OPTIONS_H_

// Parameters of active exploration (METHODS.md section 2, "Active exploration" and "Local
// traps"). Where the paper gives a value (go-stop timing, velocity limits) it is the default;
// every other default is ours and its comment says why.

#include "absl/status/status.h"

namespace waymark::laser_slam {

enum class ExplorationMode {
  kPassive,  // no suggestions
  kActive,   // optimal control, wall following in local traps
  kWander,   // the paper's baseline: straight ahead until an obstacle, then turn
};

struct ExplorationOptions {
  ExplorationMode mode = ExplorationMode::kPassive;

  // Go-stop motion (paper): a control is held for one observation period, then the robot stops
  // and scans. The control period is the step of the predicted motion (collision check).
  double observation_period = 4.0;  // s
  double control_period = 0.1;      // s
  double max_linear = 0.15;         // m/s (paper)
  double max_angular = 0.17;        // rad/s (paper)
  // Candidate controls: linear_steps velocities evenly in [0, max_linear] times angular_steps
  // evenly in [-max_angular, max_angular], without standing still (3 x 7 - 1 = 20 by default).
  // Only forward motion: the laser sees the half plane ahead, nothing behind.
  int linear_steps = 3;
  int angular_steps = 7;

  // Collision check against the last scan's returns and the map. A Pioneer 3-DX is 0.455 x 0.381 m:
  // its half diagonal is 0.30 m. The clearance absorbs the pose error of a few scans.
  double robot_radius = 0.30;  // m
  double clearance = 0.10;     // m

  // Objective J = w1 lg J1 + w21 lg J21 + w22 lg J22 (the paper gives no weights).
  double weight_uncertainty = 1.0;  // w1
  double weight_extension = 1.0;    // w21
  double weight_endpoints = 1.0;    // w22
  // lg 0 = -inf would make every candidate without exploration gain equally bad and hide J1's
  // ranking among them; a zero J21 or J22 enters as lg(zero_floor) instead. Below every gain a
  // single observation can predict (1e-3 of the mapped length is ~mm on a small map).
  double zero_floor = 1e-3;

  // Predicted observation. The laser is assumed to see a mapped line going on past a virtual
  // endpoint (the unknown is presumed wall); extensions shorter than min_extension are sampling
  // noise. Two mapped lines meeting within corner_reach past their virtual endpoints (at more than
  // corner_angle) predict a corner there: the extension stops at it and, if the corner is in view,
  // the endpoint is predicted to turn real (J22).
  double sample_step = 0.05;     // m along a line
  double min_extension = 0.2;    // m
  double corner_reach = 1.0;     // m
  double corner_angle = 0.5;     // rad (~30 degrees)

  // Local traps. Wall following starts when no candidate predicts any exploration gain
  // (J21 = J22 = 0) for trap_decisions decisions in a row, or when the map has not grown
  // (mapped length, segments, real endpoints) for stall_decisions decisions although gains were
  // predicted (the predicted wall was not there). It ends once the map grew by exit_growth metres
  // of mapped length or by a segment or a real endpoint since it started.
  int trap_decisions = 2;
  int stall_decisions = 12;
  // Wall following that has not grown the map for this many decisions gives way to wandering
  // until the map grows (see exploration_planner.h).
  int escape_after = 15;
  double exit_growth = 1.0;  // m
  // Wall following: offset of the tracking line from the wall, distance from the tracked
  // segment's end at which to switch to the adjacent one, the gap within which two segment ends
  // are adjacent, and how far ahead on the tracking line the robot aims.
  double wall_offset = 0.8;       // m
  double switch_distance = 0.8;   // m
  double adjacency = 0.5;         // m
  double lookahead = 1.0;         // m
};

absl::Status ValidateExplorationOptions(const ExplorationOptions& options);

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_EXPLORATION_EXPLORATION_OPTIONS_H_
