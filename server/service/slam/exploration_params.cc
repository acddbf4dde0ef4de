#include "server/service/slam/exploration_params.h"

#include <cmath>
#include <string>

#include "absl/strings/str_cat.h"
#include "server/service/slam/slam_params.h"

namespace waymark::service {
namespace {

namespace ls = laser_slam;

constexpr char kField[] = "laser.exploration.";

}  // namespace

absl::Status ApplyExplorationConfig(const v1::ExplorationConfig& c, ls::ExplorationOptions* o) {
  switch (c.mode()) {
    case v1::ExplorationConfig::PASSIVE: o->mode = ls::ExplorationMode::kPassive; break;
    case v1::ExplorationConfig::ACTIVE: o->mode = ls::ExplorationMode::kActive; break;
    case v1::ExplorationConfig::WANDER: o->mode = ls::ExplorationMode::kWander; break;
    case v1::ExplorationConfig::FRONTIER: o->mode = ls::ExplorationMode::kFrontier; break;
    default:
      return absl::InvalidArgumentError(absl::StrCat(
          kField, "mode ", static_cast<int>(c.mode()),
          " is not a mode (0 PASSIVE, 1 ACTIVE, 2 WANDER, 3 FRONTIER)"));
  }
  struct Field {
    bool set;
    double value;
    const char* name;
    double lo, hi;
    bool lo_open;
    const char* unit;
    double* target;
  };
  const Field fields[] = {
      {c.has_max_linear(), c.max_linear(), "max_linear", 0.0, 2.0, true, "m/s", &o->max_linear},
      {c.has_max_angular(), c.max_angular(), "max_angular", 0.0, 3.0, true, "rad/s",
       &o->max_angular},
      {c.has_observation_period(), c.observation_period(), "observation_period", 0.0, 60.0, true,
       "s", &o->observation_period},
      {c.has_control_period(), c.control_period(), "control_period", 0.0, 10.0, true, "s",
       &o->control_period},
      {c.has_robot_radius(), c.robot_radius(), "robot_radius", 0.0, 5.0, true, "m",
       &o->robot_radius},
      {c.has_clearance(), c.clearance(), "clearance", 0.0, 5.0, false, "m", &o->clearance},
      {c.has_weight_uncertainty(), c.weight_uncertainty(), "weight_uncertainty", 0.0, 100.0, false,
       "", &o->weight_uncertainty},
      {c.has_weight_extension(), c.weight_extension(), "weight_extension", 0.0, 100.0, false, "",
       &o->weight_extension},
      {c.has_weight_endpoints(), c.weight_endpoints(), "weight_endpoints", 0.0, 100.0, false, "",
       &o->weight_endpoints},
      {c.has_wall_offset(), c.wall_offset(), "wall_offset", 0.0, 10.0, true, "m", &o->wall_offset},
      {c.has_grid_resolution(), c.grid_resolution(), "grid_resolution", 0.02, 0.5, false, "m",
       &o->grid_resolution},
      {c.has_weight_gain(), c.weight_gain(), "weight_gain", 0.0, 100.0, false, "", &o->weight_gain},
      {c.has_travel_cost(), c.travel_cost(), "travel_cost", 0.0, 100.0, false, "per m",
       &o->travel_cost},
      {c.has_weight_trip_uncertainty(), c.weight_trip_uncertainty(), "weight_trip_uncertainty",
       0.0, 100.0, false, "", &o->weight_trip_uncertainty},
      {c.has_revisit_variance(), c.revisit_variance(), "revisit_variance", 0.0, 1e6, false, "m^2",
       &o->revisit_variance},
  };
  if (c.has_goal_layer()) o->goal_layer = c.goal_layer();
  for (const Field& f : fields) {
    if (!f.set) continue;
    if (absl::Status s = InRange(f.value, std::string(kField) + f.name, f.lo, f.hi, f.lo_open, f.unit);
        !s.ok()) {
      return s;
    }
    *f.target = f.value;
  }
  if (c.has_linear_steps()) {
    if (absl::Status s = InRange(c.linear_steps(), std::string(kField) + "linear_steps", 2, 20,
                                 false, "");
        !s.ok()) {
      return s;
    }
    o->linear_steps = static_cast<int>(c.linear_steps());
  }
  if (c.has_angular_steps()) {
    if (c.angular_steps() % 2 == 0 || c.angular_steps() > 41) {
      return absl::InvalidArgumentError(absl::StrCat(
          kField, "angular_steps must be odd and at most 41 (so that straight ahead is a "
          "candidate), got ", c.angular_steps()));
    }
    o->angular_steps = static_cast<int>(c.angular_steps());
  }
  if (absl::Status s = ls::ValidateExplorationOptions(*o); !s.ok()) {
    return absl::InvalidArgumentError(absl::StrCat(kField, " ", s.message()));
  }
  return absl::OkStatus();
}

void FillEffectiveExploration(const ls::ExplorationOptions& o, v1::ExplorationConfig* c) {
  switch (o.mode) {
    case ls::ExplorationMode::kPassive: c->set_mode(v1::ExplorationConfig::PASSIVE); break;
    case ls::ExplorationMode::kActive: c->set_mode(v1::ExplorationConfig::ACTIVE); break;
    case ls::ExplorationMode::kWander: c->set_mode(v1::ExplorationConfig::WANDER); break;
    case ls::ExplorationMode::kFrontier: c->set_mode(v1::ExplorationConfig::FRONTIER); break;
  }
  c->set_max_linear(o.max_linear);
  c->set_max_angular(o.max_angular);
  c->set_observation_period(o.observation_period);
  c->set_control_period(o.control_period);
  c->set_linear_steps(static_cast<uint32_t>(o.linear_steps));
  c->set_angular_steps(static_cast<uint32_t>(o.angular_steps));
  c->set_robot_radius(o.robot_radius);
  c->set_clearance(o.clearance);
  c->set_weight_uncertainty(o.weight_uncertainty);
  c->set_weight_extension(o.weight_extension);
  c->set_weight_endpoints(o.weight_endpoints);
  c->set_wall_offset(o.wall_offset);
  c->set_goal_layer(o.mode == ls::ExplorationMode::kFrontier || o.goal_layer);
  c->set_grid_resolution(o.grid_resolution);
  c->set_weight_gain(o.weight_gain);
  c->set_travel_cost(o.travel_cost);
  c->set_weight_trip_uncertainty(o.weight_trip_uncertainty);
  c->set_revisit_variance(o.revisit_variance);
}

void FillSuggestion(const ls::Suggestion& s, v1::SuggestedControl* c) {
  c->set_linear(s.linear);
  c->set_angular(s.angular);
  c->set_duration(s.duration);
  switch (s.behaviour) {
    case ls::Behaviour::kNone: c->set_behaviour(v1::SuggestedControl::BEHAVIOUR_UNSPECIFIED); break;
    case ls::Behaviour::kOptimal: c->set_behaviour(v1::SuggestedControl::OPTIMAL); break;
    case ls::Behaviour::kWallFollowing: c->set_behaviour(v1::SuggestedControl::WALL_FOLLOWING); break;
    case ls::Behaviour::kWander: c->set_behaviour(v1::SuggestedControl::WANDER); break;
    case ls::Behaviour::kBlocked: c->set_behaviour(v1::SuggestedControl::BLOCKED); break;
    case ls::Behaviour::kToTarget: c->set_behaviour(v1::SuggestedControl::TO_TARGET); break;
    case ls::Behaviour::kFinished: c->set_behaviour(v1::SuggestedControl::FINISHED); break;
  }
  c->set_j(s.score.j);
  c->set_j1(s.score.j1);
  c->set_j21(s.score.j21);
  c->set_j22(s.score.j22);
  c->set_candidates(static_cast<uint32_t>(s.candidates));
  c->set_feasible(static_cast<uint32_t>(s.feasible));
  c->set_tracked_segment(s.tracked_segment);
  c->set_planning_ms(s.planning_ms);
}

void FillExplorationProgress(const ls::GoalProgress& p, v1::ExplorationProgress* out) {
  switch (p.state) {
    case ls::ExplorationState::kExploring: out->set_state(v1::ExplorationProgress::EXPLORING); break;
    case ls::ExplorationState::kDone: out->set_state(v1::ExplorationProgress::DONE); break;
    case ls::ExplorationState::kStuck: out->set_state(v1::ExplorationProgress::STUCK); break;
  }
  out->set_reason(p.reason);
  out->set_open_boundary(p.open_share);
  out->set_targets_left(static_cast<uint32_t>(p.targets_left));
  out->set_unreachable_regions(static_cast<uint32_t>(p.unreachable));
  out->set_given_up(static_cast<uint32_t>(p.given_up));
  out->set_known_area(p.known_area);
  out->set_unmapped_walls(static_cast<uint32_t>(p.unmapped_walls));
  out->set_travel(p.travel);
  if (p.target) {
    switch (p.target->kind) {
      case ls::TargetKind::kFrontier: out->set_target_kind(v1::ExplorationProgress::FRONTIER); break;
      case ls::TargetKind::kRevisit: out->set_target_kind(v1::ExplorationProgress::REVISIT); break;
      case ls::TargetKind::kWall: out->set_target_kind(v1::ExplorationProgress::UNMAPPED_WALL); break;
    }
    out->mutable_target()->set_x(p.target->goal.x());
    out->mutable_target()->set_y(p.target->goal.y());
    out->mutable_look_at()->set_x(p.target->look_at.x());
    out->mutable_look_at()->set_y(p.target->look_at.y());
    out->set_path_length(p.target->path_length);
    out->set_target_utility(p.target->utility);
  }
  // The path's cells are 0.1 m apart; a point every 0.5 m draws it as well.
  constexpr double kSpacing = 0.5;
  for (size_t i = 0; i < p.path.size(); ++i) {
    const bool last = i + 1 == p.path.size();
    if (!last && out->path_size() > 0) {
      const v1::Pose2D& prev = out->path(out->path_size() - 1);
      if (std::hypot(p.path[i].x() - prev.x(), p.path[i].y() - prev.y()) < kSpacing) continue;
    }
    v1::Pose2D* point = out->add_path();
    point->set_x(p.path[i].x());
    point->set_y(p.path[i].y());
  }
}

}  // namespace waymark::service
