#include "server/laser_slam/exploration/exploration_planner.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include <Eigen/LU>

#include "server/common/stopwatch.h"
#include "server/laser_slam/exploration/clearance.h"
#include "server/laser_slam/geometry.h"
#include "server/laser_slam/motion.h"
#include "server/laser_slam/exploration/path_following.h"

namespace waymark::laser_slam {
namespace {

// The map counts as grown when its length increases by more than this (m): merges and endpoint
// noise move the total by centimetres.
constexpr double kGrowthEpsilon = 0.1;

}  // namespace

const char* BehaviourName(Behaviour behaviour) {
  switch (behaviour) {
    case Behaviour::kNone: return "none";
    case Behaviour::kOptimal: return "optimal";
    case Behaviour::kWallFollowing: return "wall-following";
    case Behaviour::kWander: return "wander";
    case Behaviour::kBlocked: return "blocked";
    case Behaviour::kToTarget: return "to-target";
    case Behaviour::kFinished: return "finished";
  }
  return "unknown";
}

ExplorationPlanner::ExplorationPlanner(const ExplorationOptions& options)
    : options_(options), follower_(options), wander_(options) {
  const bool frontier = options.mode == ExplorationMode::kFrontier;
  if (frontier || (options.mode == ExplorationMode::kActive && options.goal_layer)) {
    goals_ = std::make_unique<ExplorationGoals>(options, /*nearest_only=*/frontier);
  }
}

std::vector<Control> ExplorationPlanner::Candidates() const {
  std::vector<Control> out;
  const int half = options_.angular_steps / 2;
  const double dw = half > 0 ? options_.max_angular / half : 0.0;
  for (int i = options_.linear_steps - 1; i >= 0; --i) {
    const double v = options_.max_linear * i / (options_.linear_steps - 1);
    for (int k = 0; k <= half; ++k) {
      for (int sign : {1, -1}) {
        if (k == 0 && sign < 0) continue;
        const double w = sign * k * dw;
        if (v == 0.0 && w == 0.0) continue;
        out.push_back(Control{v, w});
      }
    }
  }
  return out;
}

ControlScore ExplorationPlanner::Score(const ExplorationView& view,
                                       const ObservationPredictor& predictor,
                                       const MapTotals& totals, const Control& control) const {
  const Pose2 u = UnicycleArc(control.linear, control.angular, options_.observation_period);
  const Eigen::Matrix3d c = PredictRobotCovariance(view.robot_covariance, u, view.odometry);
  const double u_min = M_PI * view.odometry.xy_min * view.odometry.xy_min * view.odometry.theta_min;
  const double uncertainty = M_PI * std::sqrt(std::max(c.determinant(), 0.0)) + view.map_uncertainty;
  ControlScore score;
  score.j1 = uncertainty > 0.0 ? u_min / uncertainty : 1.0;
  const ExplorationGain gain = predictor.Predict(Compose(view.robot, u));
  score.j21 = totals.length > 0.0 ? gain.extension / totals.length : 0.0;
  score.j22 = totals.segments > 0 ? gain.new_real_endpoints / (2.0 * totals.segments) : 0.0;
  score.j = options_.weight_uncertainty * Lg(score.j1, std::numeric_limits<double>::min()) +
            options_.weight_extension * Lg(score.j21, options_.zero_floor) +
            options_.weight_endpoints * Lg(score.j22, options_.zero_floor);
  return score;
}

void ExplorationPlanner::UpdateTrapState(const MapTotals& totals, bool any_gain) {
  const bool grew = !have_totals_ || totals.length > largest_.length + kGrowthEpsilon;
  if (grew) largest_ = totals;
  have_totals_ = true;
  if (following_) {
    if (totals.length >= follow_start_.length + options_.exit_growth) {
      following_ = false;  // step 4: the map grows again
      escaping_ = false;
      zero_streak_ = 0;
      stall_ = 0;
      return;
    }
    stall_ = grew ? 0 : stall_ + 1;
    // Wall following that has found nothing for a long time (round and round a room whose
    // doorway it cannot see as an opening, up and down a dead end) hands over to wandering.
    if (stall_ >= options_.escape_after) escaping_ = true;
    return;
  }
  zero_streak_ = any_gain ? 0 : zero_streak_ + 1;
  stall_ = grew ? 0 : stall_ + 1;
  if (zero_streak_ >= options_.trap_decisions || stall_ >= options_.stall_decisions) {
    following_ = true;
    escaping_ = false;
    follow_start_ = totals;
    zero_streak_ = 0;
    stall_ = 0;
  }
}

std::optional<Control> ExplorationPlanner::DecideLocally(const ExplorationView& view,
                                                        const ClearanceMap& clearance,
                                                        const std::vector<Control>& feasible,
                                                        Suggestion* s) {
  if (options_.mode != ExplorationMode::kActive) {  // wander, and FRONTIER without a target
    s->behaviour = Behaviour::kWander;
    return wander_.Choose(view, clearance);
  }
  if (feasible.empty()) return std::nullopt;
  const double travel = options_.max_linear * options_.observation_period;
  const ObservationPredictor predictor(view, options_, travel);
  const MapTotals totals = Totals(view.segments);
  std::vector<ControlScore> scores;
  scores.reserve(feasible.size());
  bool any_gain = false;
  int best = 0;
  for (size_t i = 0; i < feasible.size(); ++i) {
    scores.push_back(Score(view, predictor, totals, feasible[i]));
    any_gain = any_gain || scores[i].j21 > 0.0 || scores[i].j22 > 0.0;
    if (scores[i].j > scores[best].j) best = static_cast<int>(i);
  }
  UpdateTrapState(totals, any_gain);
  if (!following_) {
    s->behaviour = Behaviour::kOptimal;
    s->score = scores[best];
    return feasible[best];
  }
  std::optional<Control> chosen;
  if (!escaping_) {
    chosen = follower_.Choose(view, feasible);
    s->behaviour = Behaviour::kWallFollowing;
    s->tracked_segment = follower_.tracked_segment();
  }
  if (!chosen) {  // nothing mapped to follow yet, or escaping a wall-following loop
    chosen = wander_.Choose(view, clearance);
    s->behaviour = Behaviour::kWander;
  }
  s->score = Score(view, predictor, totals, *chosen);
  return chosen;
}

std::optional<Control> ExplorationPlanner::FollowTarget(const ExplorationView& view,
                                                        const std::vector<Control>& feasible,
                                                        const GoalProgress& progress,
                                                        Suggestion* s) const {
  if (feasible.empty()) return std::nullopt;
  const Eigen::Vector2d robot(view.robot.x, view.robot.y);
  const double period = options_.observation_period;
  if (progress.arrived) {  // at the goal: face what it is for (the laser sees ahead only)
    const Control* turn = TurnTowards(view.robot, progress.target->look_at, feasible, period);
    if (turn) return *turn;
  }
  // Metres of cost per radian of heading error at the arc's end: a quarter turn weighs about
  // half a metre of path.
  constexpr double kHeadingWeight = 0.3;
  // Each control is rated by where its arc ends on the navigation function (the cost to the goal
  // from there) plus how far it would then have to turn to face the path ahead. Turning in place
  // keeps the cost and fixes the heading; a blocked direction is simply not a candidate.
  const double here = goals_->CostToGoal(robot);
  std::vector<double> ratings, gains;
  ratings.reserve(feasible.size());
  gains.reserve(feasible.size());
  int best = -1;
  for (size_t i = 0; i < feasible.size(); ++i) {
    const Pose2 end = Compose(view.robot, UnicycleArc(feasible[i].linear, feasible[i].angular,
                                                      period));
    const Eigen::Vector2d at(end.x, end.y);
    const Eigen::Vector2d aim = goals_->AimFrom(at, options_.path_lookahead);
    const double cost = goals_->CostToGoal(at);
    gains.push_back(here - cost);
    ratings.push_back(cost + kHeadingWeight * std::abs(BearingError(end, aim)));
    // No turning back the way the last turn in place came: two headings either side of the
    // path's direction, each blocked a little differently, would make the robot dither between
    // them for ever; going on round finds the way out. (Allowing one reversal was tried: in the
    // cluttered world the robot then spent whole runs turning.)
    const bool turns_back = feasible[i].linear == 0.0 && last_turn_ * feasible[i].angular < 0.0;
    if (std::isfinite(ratings[i]) && !turns_back && (best < 0 || ratings[i] < ratings[best])) {
      best = static_cast<int>(i);
    }
  }
  if (best < 0) {  // every arc ends off the path's cells: turn towards the path
    const Control* turn = TurnTowards(view.robot, LookaheadPoint(progress.path, robot,
                                                                 options_.path_lookahead),
                                      feasible, period);
    if (!turn) return std::nullopt;
    return *turn;
  }
  // FRONTIER mode, and any decision where the best move only turns the robot (the paper's J
  // would choose between turning left and right and make it dither): the best rating.
  constexpr double kMinGain = 0.05;  // m of path: the best control drives towards the goal
  if (options_.mode != ExplorationMode::kActive || !(gains[best] > kMinGain)) {
    return feasible[best];
  }
  // ACTIVE: the paper's objective chooses among the controls that drive towards the goal about
  // as well as the best one (rating and gain within progress_slack of its own): the way there,
  // not a slower pace (J1 alone would always prefer driving less).
  const double travel = options_.max_linear * period;
  const ObservationPredictor predictor(view, options_, travel);
  const MapTotals totals = Totals(view.segments);
  int chosen = -1;
  for (size_t i = 0; i < feasible.size(); ++i) {
    if (!(ratings[i] <= ratings[best] + options_.progress_slack) ||
        gains[i] < gains[best] - options_.progress_slack) {
      continue;
    }
    const ControlScore score = Score(view, predictor, totals, feasible[i]);
    if (chosen < 0 || score.j > s->score.j) {
      chosen = static_cast<int>(i);
      s->score = score;
    }
  }
  return feasible[chosen];
}

Suggestion ExplorationPlanner::Decide(const ExplorationView& view) {
  const auto start = Clock::now();
  Suggestion s;
  s.duration = options_.observation_period;
  const double travel = options_.max_linear * options_.observation_period;
  const double required = options_.robot_radius + options_.clearance;
  const double reach = travel + required + 0.5;
  // The goal layer integrates the scan first, so its grid's walls guard the collision check too.
  const GoalProgress* progress = goals_ ? &goals_->Update(view, blocked_) : nullptr;
  const ClearanceMap clearance(
      view, reach,
      goals_ ? goals_->OccupiedNear(Eigen::Vector2d(view.robot.x, view.robot.y), reach)
             : std::vector<Eigen::Vector2d>{});
  const std::vector<Control> candidates = Candidates();
  std::vector<Control> feasible;
  for (const Control& c : candidates) {
    if (PathIsFree(clearance, c.linear, c.angular, options_.observation_period,
                   options_.control_period, required)) {
      feasible.push_back(c);
    }
  }
  s.candidates = static_cast<int>(candidates.size());
  s.feasible = static_cast<int>(feasible.size());

  std::optional<Control> chosen;
  if (progress) {
    if (progress->state != ExplorationState::kExploring || progress->waiting) {
      // Over, or (several robots) waiting while nearer robots explore what is left: stand.
      s.behaviour = Behaviour::kFinished;
      chosen = Control{0.0, 0.0};
    } else if (progress->target && !progress->path.empty()) {
      chosen = FollowTarget(view, feasible, *progress, &s);
      if (chosen) s.behaviour = Behaviour::kToTarget;
    }
  }
  if (!chosen) chosen = DecideLocally(view, clearance, feasible, &s);
  last_turn_ = chosen && chosen->linear == 0.0 ? chosen->angular : 0.0;
  blocked_ = feasible.empty();
  if (!chosen) {
    s.behaviour = Behaviour::kBlocked;
    chosen = Control{0.0, 0.0};
  }
  s.linear = chosen->linear;
  s.angular = chosen->angular;
  s.planning_ms = MsSince(start);
  return s;
}

}  // namespace waymark::laser_slam
