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
  // A frontier explorer as users know them (explore_lite, nav2's): drive to the nearest frontier
  // along a grid path, no uncertainty term, no revisits. The baseline the goal layer is measured
  // against.
  kFrontier,
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

  // The goal layer (goal_layer.h), above the one-step planner in ACTIVE mode and alone in
  // FRONTIER mode. goal_layer = false in ACTIVE mode is the paper's planner exactly as published.
  bool goal_layer = true;
  // Exploration grid: 0.1 m keeps a 40 x 30 m floor at 120 k cells (a decision's Dijkstra is one
  // pass over them) and still resolves a 1 m doorway for a 0.8 m wide robot disc.
  double grid_resolution = 0.1;  // m
  // Frontier regions shorter than this many cells are gaps past a corner, not places to go.
  int min_frontier_cells = 5;
  // A frontier is reached from any traversable cell within approach_radius of it (the laser sees
  // 8 m: standing on the frontier itself is not needed, and next to walls it is not possible).
  double approach_radius = 1.0;  // m
  double arrive_radius = 0.4;    // m: the robot has reached a target's goal cell
  double face_tolerance = 0.6;   // rad: ... and faces the frontier (the laser sees ahead only)
  double path_lookahead = 1.2;   // m along the path: the point the controls aim at
  // Unmapped walls (ACTIVE): occupied cells farther than wall_explained from every segment are
  // looked at from wall_view_min..wall_view_max away (the extraction fits lines to beams within
  // its 6 m range at more than its incidence limit; 3 m gives dense beams).
  double wall_explained = 0.2;  // m
  double wall_view_min = 0.8;   // m
  double wall_view_max = 3.0;   // m
  // Paths keep comfort_distance from walls where they can (see grid_paths.h).
  double comfort_distance = 0.8;  // m
  double wall_penalty = 2.0;
  // Among the controls that follow the path within progress_slack (m) of the best one, ACTIVE
  // mode takes the one the paper's objective J prefers.
  double progress_slack = 0.15;  // m
  // Target utility (ACTIVE): U = weight_gain lg(gain) - travel_cost L - weight_trip_uncertainty
  // lg(var_after): gain is the frontier's (or unmapped wall's) length (m), L the path length (m)
  // and var_after the robot's position variance on arrival, the filter's covariance now predicted
  // with the odometry model along L (the paper's J1 at the scale of the map). FRONTIER mode takes
  // the nearest target instead.
  double weight_gain = 1.0;
  // Per m: 5 m of extra path weigh as much as a tenfold gain. 0.2 rather than 0.1: the robot
  // finishes what is near before crossing the floor (docs/results.md has both).
  double travel_cost = 0.2;
  double weight_trip_uncertainty = 1.0;
  // Active loop closing (ACTIVE, with the loop-closing back end): once the filter's position
  // variance passes revisit_variance (m^2), places driven at least revisit_travel metres earlier
  // become targets too; their gain is gain_floor and the variance on arrival that of the place
  // when it was driven (closing the loop brings it back). After a revisit, or a loop closure,
  // none for another revisit_travel metres.
  // 0.02 m^2 is about the filter's 90th percentile in the built-in worlds: revisits happen on
  // long loops (docs/exploration.md has what they bought), not after every room.
  double revisit_variance = 0.02;
  double revisit_travel = 15.0;    // m (the back end's min_loop_travel)
  double gain_floor = 0.5;         // m
  // Keep the current target unless another one's utility is this much higher (no dithering).
  double switch_margin = 0.3;
  // A target whose path has not shortened by 0.2 m in no_progress_decisions decisions is given up
  // (a full turn in place takes 10 decisions at the paper's 0.17 rad/s).
  int no_progress_decisions = 16;
  // DONE after done_decisions decisions in a row without a target; STUCK after stuck_decisions
  // decisions in a row without a collision-free control.
  int done_decisions = 3;
  int stuck_decisions = 15;
};

absl::Status ValidateExplorationOptions(const ExplorationOptions& options);

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_EXPLORATION_EXPLORATION_OPTIONS_H_
