#ifndef WAYMARK_SERVER_LASER_SLAM_EXPLORATION_GOAL_LAYER_H_
#define WAYMARK_SERVER_LASER_SLAM_EXPLORATION_GOAL_LAYER_H_

// The goal layer above the paper's one-step planner (issue 17): where to go next at the scale of
// the map, and when exploring is over.
//
// Each decision it integrates the scan into the exploration grid (exploration_grid.h), finds the
// frontiers (frontiers.h), runs one Dijkstra from the robot (grid_paths.h) and turns every
// frontier region into a target: the cheapest traversable cell within approach_radius of one of
// its cells. ACTIVE mode ranks targets by utility (exploration_options.h: gain, travel, and the
// position variance the trip will add, predicted with the odometry model), and adds revisits of
// places driven long ago when the variance accumulated since the last loop closure is high
// (active loop closing); FRONTIER mode takes the nearest. The chosen target is kept until it is
// seen (its frontier closed), reached (then it must be faced: the laser sees ahead only),
// beaten by switch_margin, or given up (no progress, or still open once reached and faced).
//
// State: EXPLORING while a target is left; DONE after done_decisions decisions with none (the
// reason says whether open boundary remains that no path reaches); STUCK when the planner could
// not move for stuck_decisions decisions, or when every open region left was given up for lack of
// progress. Everything is in the planner's frame (the EKF's local one).
//
// With teammates (several robots in one map, shared_exploration.h) a decision runs on this
// robot's grid merged with theirs and their segments: DONE then means no target is left in what
// the robots know together. A target within kClaimRadius of one a nearer teammate claimed costs
// kClaimPenalty of utility (it stays a target: when nothing else is left, two robots may share it);
// one a teammate reached and found still open is given up. When every target left is claimed so,
// the robot waits (GoalProgress::waiting): it stands, EXPLORING, and claims nothing.

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "server/laser_slam/exploration/exploration_grid.h"
#include "server/laser_slam/exploration/exploration_options.h"
#include "server/laser_slam/exploration/exploration_types.h"
#include "server/laser_slam/exploration/frontiers.h"
#include "server/laser_slam/exploration/grid_paths.h"
#include "server/laser_slam/exploration/unmapped_walls.h"

namespace waymark::laser_slam {

enum class ExplorationState : std::uint8_t { kExploring = 1, kDone = 2, kStuck = 3 };
enum class TargetKind : std::uint8_t {
  kFrontier = 1,  // the edge of the known free space
  kRevisit = 2,   // a place driven long ago (active loop closing)
  kWall = 3,      // a wall the grid has and the segment map has not (unmapped_walls.h)
};

struct ExplorationTarget {
  TargetKind kind = TargetKind::kFrontier;
  Eigen::Vector2d goal = Eigen::Vector2d::Zero();     // where the robot drives to
  Eigen::Vector2d look_at = Eigen::Vector2d::Zero();  // what it faces there
  double gain = 0.0;         // m of frontier (gain_floor for a revisit)
  double path_length = 0.0;  // m
  double variance_after = 0.0;  // m^2, predicted position variance on arrival
  double utility = 0.0;
  bool claimed = false;  // near one a nearer teammate claimed (ClaimPenalty)
};

struct GoalProgress {
  ExplorationState state = ExplorationState::kExploring;
  std::string reason;
  double open_share = 1.0;   // of the known free space's boundary
  int targets_left = 0;      // reachable targets this decision (the chosen one included)
  int unreachable = 0;       // frontier and wall regions no path reaches (or no place sees)
  int unmapped_walls = 0;    // wall regions left (FRONTIER mode does not target them)
  int given_up = 0;          // targets abandoned so far
  std::optional<ExplorationTarget> target;
  bool arrived = false;      // at the target's goal: turn to face it
  // Several robots: every target left is claimed by a nearer teammate; the robot stands and waits
  // (EXPLORING, no target) rather than follow it into the same room.
  bool waiting = false;
  std::vector<Eigen::Vector2d> path;  // robot to goal
  double known_area = 0.0;   // m^2
  double travel = 0.0;       // m driven, by the estimate
  double position_variance = 0.0;  // m^2, the filter's (x + y) for the robot now
};

class ExplorationGoals {
 public:
  // `options` must pass ValidateExplorationOptions. `nearest_only`: FRONTIER mode's choice.
  ExplorationGoals(const ExplorationOptions& options, bool nearest_only);

  // One decision: integrates view.scan at view.robot and re-plans. `blocked`: the planner found
  // no collision-free control at the previous decision.
  const GoalProgress& Update(const ExplorationView& view, bool blocked);

  const GoalProgress& progress() const { return progress_; }
  // Centres of the occupied cells within `reach` of `point`.
  std::vector<Eigen::Vector2d> OccupiedNear(const Eigen::Vector2d& point, double reach) const;
  // Cost (path metres, weighted near walls) from `point` to the current target's goal; infinity
  // without a target or where no path reaches it. A navigation function: the local controller
  // takes the control whose arc ends lowest.
  double CostToGoal(const Eigen::Vector2d& point) const;
  // The point `lookahead` metres along the path from `point` to the goal (the goal when nearer);
  // `point` itself where no path reaches the goal.
  Eigen::Vector2d AimFrom(const Eigen::Vector2d& point, double lookahead) const;
  // The grid the last decision used: this robot's own, merged with its teammates' when it has
  // any.
  const ExplorationGrid& grid() const { return grid_; }
  // What this robot saw itself (what it tells its teammates).
  const ExplorationGrid& own_grid() const { return own_grid_; }
  // Where the robot stood at its decisions, thinned to one place per kStoodSpacing.
  const std::vector<Eigen::Vector2d>& stood() const { return stood_; }
  // Targets reached, faced and still open (given up, not for lack of progress).
  const std::vector<Eigen::Vector2d>& looked_at_open() const { return looked_at_open_; }

 private:
  struct Place {
    Eigen::Vector2d position;
    double travel;
    double variance;
  };
  void Track(const ExplorationView& view);
  // Every reachable target this decision (each with its goal cell's index in `goal_cells`).
  std::vector<ExplorationTarget> Targets(const CostField& field, const Frontiers& frontiers,
                                         const UnmappedWalls& walls, const ExplorationView& view,
                                         std::vector<int>* goal_cells);
  // Where to look at an unmapped wall from: a reachable cell in sight of it, between
  // wall_view_min and wall_view_max away, cheap to reach and facing the wall squarely.
  std::optional<ExplorationTarget> WallTarget(const CostField& field, const GridRegion& region,
                                              int* goal_cell) const;
  double Utility(const ExplorationTarget& target) const;
  // The claim penalty for a target looking at `look_at` (0 without teammates).
  double ClaimPenalty(const Eigen::Vector2d& look_at, const ExplorationView& view) const;
  // The robot's position variance (x + y) after driving `length` from here.
  double VarianceAfter(double length, const ExplorationView& view) const;
  bool GivenUp(const Eigen::Vector2d& point) const;
  void GiveUp(const Eigen::Vector2d& look_at, bool for_lack_of_progress);

  ExplorationOptions options_;
  bool nearest_only_;
  ExplorationGrid own_grid_;  // this robot's scans
  ExplorationGrid grid_;      // own_grid_ merged with the teammates' (a copy when there are none)
  std::vector<Eigen::Vector2d> stood_;
  // Cell offsets within approach_radius: where a frontier cell may be reached from.
  std::vector<Eigen::Vector2i> approach_offsets_;
  std::vector<float> distance_;  // ObstacleDistance of grid_ at this decision
  PathOptions path_options_;
  std::unique_ptr<CostField> to_goal_;  // Dijkstra from the current target's goal
  GoalProgress progress_;
  std::optional<Pose2> last_robot_;
  int last_loop_closures_ = 0;
  double revisit_blocked_until_ = 0.0;  // travel before which no revisit is proposed
  bool revisiting_ = false;  // revisits are targets (the variance passed revisit_variance)
  std::vector<Place> places_;
  std::vector<Eigen::Vector2d> given_up_;  // look-at points never to be targeted again
  std::vector<Eigen::Vector2d> stalled_;   // ... of which given up for lack of progress
  std::vector<Eigen::Vector2d> looked_at_open_;  // ... of which reached and still open
  // The teammates' looked_at_open, in this frame at this decision: given up here too.
  std::vector<Eigen::Vector2d> teammates_given_up_;
  int stalled_regions_ = 0;  // frontier regions left, given up for lack of progress (this decision)
  double best_length_ = 0.0;  // shortest path to the current target so far
  int since_progress_ = 0;
  int without_target_ = 0;
  int blocked_streak_ = 0;
};

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_EXPLORATION_GOAL_LAYER_H_
