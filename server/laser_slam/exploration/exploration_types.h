#ifndef WAYMARK_SERVER_LASER_SLAM_EXPLORATION_EXPLORATION_TYPES_H_
#define WAYMARK_SERVER_LASER_SLAM_EXPLORATION_EXPLORATION_TYPES_H_

// What the exploration planner sees of a session (ExplorationView) and what it answers
// (Suggestion).

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "server/laser_slam/exploration/shared_exploration.h"
#include "server/laser_slam/options.h"
#include "server/laser_slam/types.h"

namespace waymark::laser_slam {

// A candidate control: held for one observation period.
struct Control {
  double linear = 0.0;   // m/s
  double angular = 0.0;  // rad/s
};

struct ExplorationView {
  Pose2 robot;                                                 // map frame
  Eigen::Matrix3d robot_covariance = Eigen::Matrix3d::Zero();  // of the robot perturbation
  // pi * sum_i sqrt(det C_i) over the segments in the filter: the map's share of U(C) (eq 19).
  // The planner predicts without observation updates, so it is the same for every candidate.
  double map_uncertainty = 0.0;
  std::vector<MapSegment> segments;  // the whole map (active and frozen)
  // The last scan, as received, and where the laser sits on the robot: the obstacles the robot
  // saw last and the beam layout the predicted observation uses.
  LaserScan scan;
  Pose2 laser_pose;
  double max_range = 6.0;  // range the filter uses (extraction max_range)
  double min_incidence = 0.26;  // the extraction's incidence filter (rad)
  OdometryNoise odometry;
  // Loop constraints in the back end's graph; -1 without a back end (the paper's EKF alone), where
  // revisiting a place cannot close a loop.
  int loop_closures = -1;
  // The other robots exploring the same map (shared_exploration.h), their transforms into this
  // frame; empty for a session alone (in no map, or the only robot tied into it), which then
  // decides exactly as it always did.
  std::vector<Teammate> teammates;
};

enum class Behaviour : std::uint8_t {
  kNone = 0,
  kOptimal = 1,        // argmax of J
  kWallFollowing = 2,  // local trap
  kWander = 3,
  kBlocked = 4,        // no collision-free candidate: stand still
  kToTarget = 5,       // the goal layer: following the path to an exploration target
  kFinished = 6,       // exploration is over (DONE or STUCK): stand still
};

const char* BehaviourName(Behaviour behaviour);

// lg with a floor: a term of the paper's objective J, and of the goal layer's target utility,
// that is zero or below the floor counts as the floor (lg 0 = -inf would hide every other term).
inline double Lg(double value, double floor) { return std::log10(std::max(value, floor)); }

// The terms of the objective for one control (METHODS.md: J1, J21, J22, J).
struct ControlScore {
  double j1 = 0.0;
  double j21 = 0.0;
  double j22 = 0.0;
  double j = 0.0;
};

struct Suggestion {
  double linear = 0.0;    // m/s
  double angular = 0.0;   // rad/s
  double duration = 0.0;  // s
  Behaviour behaviour = Behaviour::kNone;
  ControlScore score;     // of the chosen control
  int candidates = 0;
  int feasible = 0;
  std::uint64_t tracked_segment = 0;  // wall following
  double planning_ms = 0.0;
};

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_EXPLORATION_EXPLORATION_TYPES_H_
