#ifndef WAYMARK_SERVER_LASER_SLAM_EXPLORATION_EXPLORATION_PLANNER_H_
#define WAYMARK_SERVER_LASER_SLAM_EXPLORATION_EXPLORATION_PLANNER_H_

// Active exploration by optimal control (METHODS.md section 2): after each scan, score every
// collision-free candidate control u (held for one observation period) by
//   J(u) = w1 lg J1 + w21 lg J21 + w22 lg J22,   u_opt = argmax J(u), where
//   J1  = U_min / U(C_k),  U(C) = pi sqrt(det C_R) + pi sum_i sqrt(det C_i)   (eq 18-19)
//         C_R predicted through u with the odometry model, no observation update; the segment
//         blocks are unchanged by a prediction, so they enter as one constant. U_min, the
//         sensor-model lower bound, is taken as the uncertainty of the smallest odometry
//         increment the model knows (its floors): a constant, so it only shifts J.
//   J21 = sum_j V_k(j) / sum_i L_{k-1}(i)   predicted virtual extension over mapped length (eq 20)
//   J22 = (sum_i N_k-(i) - sum_i N_{k-1}(i)) / 2m   predicted new real endpoints (eq 21)
// (observation_prediction.h says how V and N are predicted). Zero cases: an empty map has
// sum L = 0 and m = 0, which make J21 and J22 zero; a zero J21 or J22 enters as lg(zero_floor)
// instead of lg 0 = -inf, so that J1 still ranks the candidates without exploration gain.
//
// Local traps (step 4 of the method and its trigger): when no candidate predicts any gain for
// trap_decisions decisions in a row, or the map has not grown for stall_decisions decisions, the
// planner follows walls (wall_follower.h) until the mapped length grew by exit_growth, then
// returns to optimal control. With no map at all to follow it wanders (wander_policy.h), and so
// it does when wall following has not grown the map for escape_after decisions (ours: the
// follower can circle a room or pace a dead end for ever; wandering breaks the loop), until the
// map grows by exit_growth.
//
// The goal layer (goal_layer.h; ACTIVE with options.goal_layer, and FRONTIER mode) decides first:
// with a target, the robot follows the grid path to it, and in ACTIVE mode the paper's J chooses
// among the controls that follow the path about equally well (progress_slack), so the paper's
// objective stays the local choice; without one (the goal layer found none this decision) the
// paper's planner above decides (ACTIVE) or the robot wanders (FRONTIER); once the goal layer
// says DONE or STUCK the robot stands (Behaviour::kFinished).
//
// The planner's state (trap counters, the followed wall, the goal layer's grid and target) is not
// part of a session checkpoint: a resumed session starts again with an empty exploration grid,
// which its first scans refill.

#include <memory>
#include <optional>
#include <vector>

#include "server/laser_slam/exploration/exploration_options.h"
#include "server/laser_slam/exploration/goal_layer.h"
#include "server/laser_slam/exploration/exploration_types.h"
#include "server/laser_slam/exploration/observation_prediction.h"
#include "server/laser_slam/exploration/clearance.h"
#include "server/laser_slam/exploration/wall_follower.h"
#include "server/laser_slam/exploration/wander_policy.h"

namespace waymark::laser_slam {

class ExplorationPlanner {
 public:
  // `options` must pass ValidateExplorationOptions; mode kActive or kWander.
  explicit ExplorationPlanner(const ExplorationOptions& options);

  // The control to hold until the next scan.
  Suggestion Decide(const ExplorationView& view);

  // The candidate controls, fastest and straightest first (so ties go to them).
  std::vector<Control> Candidates() const;
  // J and its terms for one control.
  ControlScore Score(const ExplorationView& view, const ObservationPredictor& predictor,
                     const MapTotals& totals, const Control& control) const;

  bool wall_following() const { return following_; }
  // Nullptr unless the goal layer runs (ACTIVE with goal_layer, FRONTIER).
  const ExplorationGoals* goals() const { return goals_.get(); }
  const WallFollower& follower() const { return follower_; }

 private:
  void UpdateTrapState(const MapTotals& totals, bool any_gain);
  // The paper's planner (optimal control, wall following, wandering out of loops).
  std::optional<Control> DecideLocally(const ExplorationView& view, const ClearanceMap& clearance,
                                       const std::vector<Control>& feasible, Suggestion* s);
  // The control that follows the goal layer's path (or faces the reached target).
  std::optional<Control> FollowTarget(const ExplorationView& view,
                                      const std::vector<Control>& feasible,
                                      const GoalProgress& progress, Suggestion* s) const;

  ExplorationOptions options_;
  WallFollower follower_;
  WanderPolicy wander_;
  bool following_ = false;
  bool escaping_ = false;  // wall following found nothing for escape_after decisions: wander
  int zero_streak_ = 0;
  int stall_ = 0;
  bool have_totals_ = false;
  MapTotals largest_;       // the largest map seen so far (growth is measured against it)
  MapTotals follow_start_;  // the map when wall following started
  std::unique_ptr<ExplorationGoals> goals_;
  bool blocked_ = false;  // the last decision had no collision-free control
  double last_turn_ = 0.0;  // angular velocity of the last decision when it turned in place
};

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_EXPLORATION_EXPLORATION_PLANNER_H_
