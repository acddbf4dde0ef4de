#include "server/laser_slam/exploration/goal_layer.h"

#include <algorithm>
#include <cmath>
#include <limits>

#include "absl/strings/str_cat.h"
#include "server/laser_slam/geometry.h"
#include "server/laser_slam/exploration/path_following.h"
#include "server/laser_slam/motion.h"
#include <Eigen/Eigenvalues>

namespace waymark::laser_slam {
namespace {

// A place is remembered every this many metres of travel (revisit targets).
constexpr double kPlaceSpacing = 1.0;
// A path must shorten by this much to count as progress (m).
constexpr double kProgress = 0.2;
// Variances below this are the odometry model's floors, not information (m^2).
constexpr double kVarianceFloor = 1e-4;
// A reached target is still open when its frontier or wall has a cell this close to the point
// it was looking at (m).
constexpr double kStillOpenRadius = 0.25;
// A given-up target's frontier cells within this distance are not targeted again (m).
constexpr double kGivenUpRadius = 0.6;
// Several robots: a target whose look-at point is within this distance of one a teammate
// claimed is that teammate's (m; about half a room of the built-in worlds, so that two robots do
// not explore one room from two of its frontiers) unless this robot is nearer to it, and costs
// this much utility: travel_cost's 0.2 per m makes it worth a 10 m detour to go elsewhere.
constexpr double kClaimRadius = 4.0;
constexpr double kClaimPenalty = 2.0;
// Places a robot stood at, told to its teammates (their grids free a disc there), are kept this
// far apart (m).
constexpr double kStoodSpacing = 0.2;

// Whether the straight line between two cells' centres crosses no occupied cell: a frontier seen
// through a gap in a mapped wall (rays that slipped past a corner into a box) cannot be looked at
// from the far side of that wall.
// Occupied cells within `end_tolerance` (m) of `to` are ignored: a wall cell is looked at
// through its own thickness.
bool InSight(const ExplorationGrid& g, int from, int to, double end_tolerance = 0.0) {
  const Eigen::Vector2d a = g.CentreOf(from);
  const Eigen::Vector2d b = g.CentreOf(to);
  const double length = (b - a).norm();
  const int steps = static_cast<int>(std::ceil(length / (0.5 * g.resolution())));
  const int last = steps - static_cast<int>(std::floor(end_tolerance / std::max(length, 1e-9) * steps));
  for (int k = 1; k < last; ++k) {
    const Eigen::Vector2i c = g.CellOf(a + (b - a) * (static_cast<double>(k) / steps));
    if (g.At(c.x(), c.y()) == GridCell::kOccupied) return false;
  }
  return true;
}

// A frontier is looked at when the unknown beyond it is within 60 degrees of the line of sight.
constexpr double kFacingCosine = 0.5;

// The mean direction from a frontier cell to its unknown 4-neighbours (unit; zero if none).
Eigen::Vector2d OpenDirection(const ExplorationGrid& g, int x, int y) {
  Eigen::Vector2d d = Eigen::Vector2d::Zero();
  const int dx[] = {1, -1, 0, 0}, dy[] = {0, 0, 1, -1};
  for (int k = 0; k < 4; ++k) {
    if (g.Inside(x + dx[k], y + dy[k]) && g.At(x + dx[k], y + dy[k]) == GridCell::kUnknown) {
      d += Eigen::Vector2d(dx[k], dy[k]);
    }
  }
  return d.norm() > 0 ? Eigen::Vector2d(d.normalized()) : d;
}

bool WithinGivenUpRadius(const std::vector<Eigen::Vector2d>& points, const Eigen::Vector2d& p) {
  for (const Eigen::Vector2d& g : points) {
    if ((g - p).norm() <= kGivenUpRadius) return true;
  }
  return false;
}

Eigen::Vector2d Position(const Pose2& p) { return Eigen::Vector2d(p.x, p.y); }

}  // namespace

std::vector<Eigen::Vector2d> ExplorationGoals::OccupiedNear(const Eigen::Vector2d& point,
                                                           double reach) const {
  std::vector<Eigen::Vector2d> out;
  if (grid_.empty()) return out;
  const Eigen::Vector2i c = grid_.CellOf(point);
  const int r = static_cast<int>(std::ceil(reach / grid_.resolution()));
  for (int y = std::max(0, c.y() - r); y <= std::min(grid_.height() - 1, c.y() + r); ++y) {
    for (int x = std::max(0, c.x() - r); x <= std::min(grid_.width() - 1, c.x() + r); ++x) {
      if (grid_.At(x, y) != GridCell::kOccupied) continue;
      const Eigen::Vector2d centre = grid_.Centre(x, y);
      if ((centre - point).norm() <= reach) out.push_back(centre);
    }
  }
  return out;
}

double ExplorationGoals::CostToGoal(const Eigen::Vector2d& point) const {
  const int i = to_goal_ ? to_goal_->CellIndex(point) : -1;
  if (i < 0 || !to_goal_->Reachable(i)) return std::numeric_limits<double>::infinity();
  return to_goal_->Cost(i);
}

Eigen::Vector2d ExplorationGoals::AimFrom(const Eigen::Vector2d& point, double lookahead) const {
  int i = to_goal_ ? to_goal_->CellIndex(point) : -1;
  if (i < 0 || !to_goal_->Reachable(i)) return point;
  const double start = to_goal_->Length(i);
  while (to_goal_->Parent(i) >= 0 && start - to_goal_->Length(i) < lookahead) i = to_goal_->Parent(i);
  return grid_.CentreOf(i);
}

ExplorationGoals::ExplorationGoals(const ExplorationOptions& options, bool nearest_only)
    : options_(options),
      nearest_only_(nearest_only),
      own_grid_(options.grid_resolution),
      grid_(options.grid_resolution) {
  const double r = options.grid_resolution;
  const int reach = static_cast<int>(std::floor(options.approach_radius / r));
  for (int dy = -reach; dy <= reach; ++dy) {
    for (int dx = -reach; dx <= reach; ++dx) {
      if (std::hypot(dx, dy) * r <= options.approach_radius) approach_offsets_.emplace_back(dx, dy);
    }
  }
}

void ExplorationGoals::Track(const ExplorationView& view) {
  if (last_robot_) {
    const Pose2 u = Relative(*last_robot_, view.robot);
    const double d = std::hypot(u.x, u.y);
    progress_.travel += d;
  }
  last_robot_ = view.robot;
  // A loop just closed by the back end: no revisit is needed for a while.
  if (view.loop_closures > last_loop_closures_) {
    revisit_blocked_until_ = progress_.travel + options_.revisit_travel;
    revisiting_ = false;
  }
  last_loop_closures_ = std::max(last_loop_closures_, view.loop_closures);
  progress_.position_variance = view.robot_covariance(0, 0) + view.robot_covariance(1, 1);
  if (stood_.empty() || (stood_.back() - Position(view.robot)).norm() >= kStoodSpacing) {
    stood_.push_back(Position(view.robot));
  }
  if (places_.empty() || progress_.travel - places_.back().travel >= kPlaceSpacing) {
    places_.push_back({Position(view.robot), progress_.travel, progress_.position_variance});
  }
}

double ExplorationGoals::VarianceAfter(double length, const ExplorationView& view) const {
  // The paper's odometry model along the path, in steps of one observation period's travel as
  // the robot will drive it, from the filter's covariance now (no observation update: J1's
  // prediction at the scale of the map).
  const double step = options_.max_linear * options_.observation_period;
  const int steps = static_cast<int>(std::ceil(length / step));
  Eigen::Matrix3d c = view.robot_covariance;
  for (int i = 0; i < steps; ++i) {
    c = PredictRobotCovariance(c, Pose2{length / steps, 0.0, 0.0}, view.odometry);
  }
  return c(0, 0) + c(1, 1);
}

bool ExplorationGoals::GivenUp(const Eigen::Vector2d& point) const {
  return WithinGivenUpRadius(given_up_, point) || WithinGivenUpRadius(teammates_given_up_, point);
}

void ExplorationGoals::GiveUp(const Eigen::Vector2d& look_at, bool for_lack_of_progress) {
  given_up_.push_back(look_at);
  if (for_lack_of_progress) stalled_.push_back(look_at);
  if (!for_lack_of_progress) looked_at_open_.push_back(look_at);
  ++progress_.given_up;
}

double ExplorationGoals::Utility(const ExplorationTarget& t) const {
  if (nearest_only_) return -t.path_length;
  return options_.weight_gain * Lg(t.gain, options_.gain_floor) -
         options_.travel_cost * t.path_length -
         options_.weight_trip_uncertainty * Lg(t.variance_after, kVarianceFloor);
}

double ExplorationGoals::ClaimPenalty(const Eigen::Vector2d& look_at,
                                     const ExplorationView& view) const {
  const Eigen::Vector2d robot = Position(view.robot);
  for (const Teammate& t : view.teammates) {
    if (t.snapshot == nullptr || t.snapshot->finished || !t.snapshot->claim) continue;
    const Eigen::Vector2d claim = MoveBy(t.to_here, *t.snapshot->claim);
    if ((claim - look_at).norm() > kClaimRadius) continue;
    const Eigen::Vector2d mate = MoveBy(t.to_here, Position(t.snapshot->robot));
    // The nearer robot keeps it: both robots reach the same verdict from the same positions.
    if ((mate - claim).norm() < (robot - claim).norm()) return kClaimPenalty;
  }
  return 0.0;
}

std::optional<ExplorationTarget> ExplorationGoals::WallTarget(const CostField& field,
                                                              const GridRegion& region,
                                                              int* goal_cell) const {
  const ExplorationGrid& g = grid_;
  // The wall's direction: the principal axis of its cells.
  Eigen::Matrix2d scatter = Eigen::Matrix2d::Zero();
  int look = region.cells.front();
  for (int cell : region.cells) {
    const Eigen::Vector2d d = g.CentreOf(cell) - region.centroid;
    scatter += d * d.transpose();
    const Eigen::Vector2d l = g.CentreOf(look) - region.centroid;
    if (d.squaredNorm() < l.squaredNorm()) look = cell;
  }
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> eigen(scatter);
  const Eigen::Vector2d along = eigen.eigenvectors().col(1);
  const Eigen::Vector2d at = g.CentreOf(look);
  // Metres of path a grazing view costs against a square one.
  constexpr double kGrazingCost = 2.0;
  const int reach = static_cast<int>(std::ceil(options_.wall_view_max / g.resolution()));
  const Eigen::Vector2i c = g.CellOf(at);
  int best = -1;
  double best_score = 0.0;
  for (int dy = -reach; dy <= reach; ++dy) {
    for (int dx = -reach; dx <= reach; ++dx) {
      const int x = c.x() + dx, y = c.y() + dy;
      if (!g.Inside(x, y)) continue;
      const int j = g.Index(x, y);
      if (!field.Reachable(j)) continue;
      const Eigen::Vector2d ray = at - g.Centre(x, y);
      const double range = ray.norm();
      if (range < options_.wall_view_min || range > options_.wall_view_max) continue;
      const double score = field.Cost(j) + kGrazingCost * std::abs(ray.dot(along)) / range;
      if ((best < 0 || score < best_score) && InSight(g, j, look, options_.wall_explained)) {
        best = j;
        best_score = score;
      }
    }
  }
  if (best < 0) return std::nullopt;
  ExplorationTarget t;
  t.kind = TargetKind::kWall;
  t.goal = g.CentreOf(best);
  t.look_at = at;
  t.path_length = field.Length(best);
  *goal_cell = best;
  return t;
}

std::vector<ExplorationTarget> ExplorationGoals::Targets(const CostField& field,
                                                         const Frontiers& frontiers,
                                                         const UnmappedWalls& walls,
                                                         const ExplorationView& view,
                                                         std::vector<int>* goal_cells) {
  const ExplorationGrid& g = grid_;
  std::vector<ExplorationTarget> targets;
  progress_.unreachable = 0;
  stalled_regions_ = 0;
  for (const GridRegion& region : frontiers.regions) {
    int open = 0, best_goal = -1, best_cell = -1;
    bool stalled = false;  // some of it was given up for lack of progress
    for (int cell : region.cells) {
      const int x = cell % g.width(), y = cell / g.width();
      const Eigen::Vector2d f = g.Centre(x, y);
      if (GivenUp(f)) {
        stalled = stalled || WithinGivenUpRadius(stalled_, f);
        continue;
      }
      ++open;
      // Which way the unknown lies from this frontier cell: the goal must look that way, or the
      // robot would only see along the frontier (the edge of a box's shadow stays an edge when
      // seen from where the shadow was cast).
      const Eigen::Vector2d into = OpenDirection(g, x, y);
      for (const Eigen::Vector2i& o : approach_offsets_) {
        if (!g.Inside(x + o.x(), y + o.y())) continue;
        const int j = g.Index(x + o.x(), y + o.y());
        if (!field.Reachable(j) || (best_goal >= 0 && field.Cost(j) >= field.Cost(best_goal))) {
          continue;
        }
        const Eigen::Vector2d look = f - g.Centre(x + o.x(), y + o.y());
        if (look.norm() > g.resolution() && look.dot(into) < kFacingCosine * look.norm()) continue;
        if (InSight(g, j, cell)) {
          best_goal = j;
          best_cell = cell;
        }
      }
    }
    if (open < options_.min_frontier_cells) {  // what is left of it was given up
      stalled_regions_ += stalled;
      continue;
    }
    if (best_goal < 0) {
      ++progress_.unreachable;
      continue;
    }
    ExplorationTarget t;
    t.kind = TargetKind::kFrontier;
    t.goal = g.CentreOf(best_goal);
    t.look_at = g.CentreOf(best_cell);
    t.gain = open * g.resolution();
    t.path_length = field.Length(best_goal);
    t.variance_after = VarianceAfter(t.path_length, view);
    const double penalty = ClaimPenalty(t.look_at, view);
    t.utility = Utility(t) - penalty;
    t.claimed = penalty > 0.0;
    targets.push_back(t);
    goal_cells->push_back(best_goal);
  }
  // Walls the segment map lacks (not in FRONTIER mode: a frontier explorer knows no segments),
  // once no frontier is left to go to: the floor first, then the walls it showed only at grazing
  // angles (looking at those on the way costs a detour per wall, and most of them turn into
  // segments anyway as the robot drives by).
  progress_.unmapped_walls = 0;
  const bool frontier_targets = !targets.empty();
  if (!nearest_only_) {
    for (const GridRegion& region : walls.regions) {
      GridRegion open;
      for (int cell : region.cells) {
        if (!GivenUp(g.CentreOf(cell))) open.cells.push_back(cell);
      }
      if (static_cast<int>(open.cells.size()) < 2 * options_.min_frontier_cells) continue;
      for (int cell : open.cells) open.centroid += g.CentreOf(cell);
      open.centroid /= static_cast<double>(open.cells.size());
      ++progress_.unmapped_walls;
      if (frontier_targets) continue;
      int goal = -1;
      std::optional<ExplorationTarget> t = WallTarget(field, open, &goal);
      if (!t) {
        ++progress_.unreachable;
        continue;
      }
      t->gain = open.cells.size() * g.resolution();
      t->variance_after = VarianceAfter(t->path_length, view);
      const double penalty = ClaimPenalty(t->look_at, view);
      t->utility = Utility(*t) - penalty;
      t->claimed = penalty > 0.0;
      targets.push_back(*t);
      goal_cells->push_back(goal);
    }
  }
  // Active loop closing: only with a back end to close the loop (loop_closures >= 0).
  // Once the variance passed the threshold, revisits stay targets until one is reached or a loop
  // closes: the filter's variance wobbles round the threshold from scan to scan, and a target
  // that comes and goes with it would have the robot turn back and forth.
  revisiting_ = !nearest_only_ && view.loop_closures >= 0 &&
                progress_.travel >= revisit_blocked_until_ &&
                (revisiting_ || progress_.position_variance > options_.revisit_variance);
  if (revisiting_) {
    for (const Place& p : places_) {
      if (progress_.travel - p.travel < options_.revisit_travel) break;  // places are in order
      const Eigen::Vector2i c = g.CellOf(p.position);
      if (!g.Inside(c.x(), c.y())) continue;
      const int j = g.Index(c.x(), c.y());
      if (!field.Reachable(j)) continue;
      ExplorationTarget t;
      t.kind = TargetKind::kRevisit;
      t.goal = g.Centre(c.x(), c.y());
      t.look_at = t.goal;
      t.gain = options_.gain_floor;
      t.path_length = field.Length(j);
      t.variance_after = p.variance;
      t.utility = Utility(t);
      targets.push_back(t);
      goal_cells->push_back(j);
    }
  }
  return targets;
}

const GoalProgress& ExplorationGoals::Update(const ExplorationView& view, bool blocked) {
  Track(view);
  blocked_streak_ = blocked ? blocked_streak_ + 1 : 0;
  own_grid_.Integrate(view.robot, view.laser_pose, view.scan, view.max_range, view.max_range,
                      options_.robot_radius);
  grid_ = own_grid_;
  MergeTeammates(view.teammates, options_.robot_radius, &grid_);
  teammates_given_up_.clear();
  for (const Teammate& t : view.teammates) {
    if (t.snapshot == nullptr) continue;
    for (const Eigen::Vector2d& p : t.snapshot->looked_at_open) {
      teammates_given_up_.push_back(MoveBy(t.to_here, p));
    }
  }
  const Frontiers frontiers = FindFrontiers(grid_, options_.min_frontier_cells);
  to_goal_.reset();  // it refers to the old distances
  distance_ = ObstacleDistance(grid_, static_cast<float>(options_.comfort_distance + 1.0));
  const Eigen::Vector2d robot = Position(view.robot);
  // Half a cell more than the collision check needs: cell centres are up to that far from the
  // walls' true positions, and a path the check then refuses makes the robot turn on the spot.
  path_options_.required_distance =
      options_.robot_radius + options_.clearance + 0.5 * grid_.resolution();
  path_options_.comfort_distance =
      std::max(options_.comfort_distance, path_options_.required_distance);
  path_options_.wall_penalty = options_.wall_penalty;
  path_options_.escape_centre = robot;
  path_options_.escape_radius = options_.robot_radius + 0.2;
  const CostField field(grid_, distance_, robot, path_options_);
  std::vector<int> goal_cells;
  // Walls shorter than 1 m (twice the frontier minimum) are not worth a trip: the extraction
  // needs several beams on a wall, and a map that drifted leaves short slivers off its segments.
  // Walls a teammate mapped are mapped.
  const UnmappedWalls walls = FindUnmappedWalls(
      grid_,
      view.teammates.empty() ? view.segments
                             : WithTeammateSegments(view.segments, view.teammates),
      options_.wall_explained, 2 * options_.min_frontier_cells);
  const std::vector<ExplorationTarget> targets =
      Targets(field, frontiers, walls, view, &goal_cells);
  // The boundary of the known free space is open where it is frontier or a wall not yet in the
  // segment map (FRONTIER mode counts frontiers only).
  const int open_cells = frontiers.open_cells + (nearest_only_ ? 0 : walls.unmapped_cells);
  const int boundary = open_cells + walls.mapped_cells + (nearest_only_ ? walls.unmapped_cells : 0);
  progress_.open_share = boundary > 0 ? static_cast<double>(open_cells) / boundary : 1.0;
  progress_.known_area = grid_.KnownArea();
  progress_.targets_left = static_cast<int>(targets.size());

  // The current target: done once it was reached and faced (the scan just integrated looked at
  // it), followed to its new goal while its frontier is open, dropped when the frontier closed.
  int current = -1;
  if (progress_.target) {
    const ExplorationTarget& t = *progress_.target;
    const bool faced = std::abs(BearingError(view.robot, t.look_at)) <= options_.face_tolerance;
    const bool reached = (robot - t.goal).norm() <= options_.arrive_radius && faced;
    for (size_t i = 0; i < targets.size() && current < 0; ++i) {
      if (targets[i].kind == t.kind && (targets[i].look_at - t.look_at).norm() <=
                                           options_.approach_radius) {
        current = static_cast<int>(i);
      }
    }
    if (reached) {
      // Looked at from its goal: whatever is still open right there is beyond this robot's
      // reach (or its laser's) and is not targeted again.
      const std::vector<char>& open = t.kind == TargetKind::kWall ? walls.mask : frontiers.mask;
      if (t.kind == TargetKind::kRevisit) {
        revisit_blocked_until_ = progress_.travel + options_.revisit_travel;
        revisiting_ = false;
      } else if (MaskedNear(grid_, open, t.look_at, kStillOpenRadius)) {
        GiveUp(t.look_at, /*for_lack_of_progress=*/false);
      }
      current = -1;
    } else if (current >= 0) {
      if (targets[current].path_length < best_length_ - kProgress) {
        best_length_ = targets[current].path_length;
        since_progress_ = 0;
      } else if (++since_progress_ >= options_.no_progress_decisions) {
        GiveUp(t.look_at, /*for_lack_of_progress=*/true);
        current = -1;
      }
    }
  }
  // Given-up targets are out of this decision's list from the next one on; skip them now.
  int best = -1;
  for (size_t i = 0; i < targets.size(); ++i) {
    if (targets[i].kind != TargetKind::kRevisit && GivenUp(targets[i].look_at)) continue;
    if (best < 0 || targets[i].utility > targets[best].utility) best = static_cast<int>(i);
  }
  if (current >= 0 && GivenUp(targets[current].look_at) &&
      targets[current].kind != TargetKind::kRevisit) {
    current = -1;
  }
  int chosen = current;
  if (best >= 0 &&
      (current < 0 || targets[best].utility > targets[current].utility + options_.switch_margin)) {
    chosen = best;
  }
  // Several robots: when all that is left is claimed by nearer teammates, wait for them.
  progress_.waiting = false;
  if (chosen >= 0 && targets[chosen].claimed) {
    bool all_claimed = true;
    for (const ExplorationTarget& t : targets) {
      all_claimed = all_claimed && (t.claimed || (t.kind != TargetKind::kRevisit &&
                                                  GivenUp(t.look_at)));
    }
    if (all_claimed) {
      progress_.waiting = true;
      chosen = -1;
    }
  }
  if (chosen != current) {
    best_length_ = chosen >= 0 ? targets[chosen].path_length : 0.0;
    since_progress_ = 0;
  }
  if (chosen >= 0) {
    progress_.target = targets[chosen];
    // The controls' arcs end within one observation period's travel of the robot: the field
    // from the goal is needed up to there (in cost: that travel at the highest step cost), plus
    // a cell.
    PathOptions from_goal = path_options_;
    from_goal.stop_near = robot;
    from_goal.stop_margin = (options_.max_linear * options_.observation_period +
                             2.0 * grid_.resolution()) *
                            (1.0 + options_.wall_penalty);
    to_goal_ = std::make_unique<CostField>(grid_, distance_, targets[chosen].goal, from_goal);
    progress_.path = to_goal_->PathTo(to_goal_->CellIndex(robot));  // goal first
    std::reverse(progress_.path.begin(), progress_.path.end());
    progress_.arrived = (robot - targets[chosen].goal).norm() <= options_.arrive_radius;
  } else {
    progress_.target.reset();
    progress_.path.clear();
    progress_.arrived = false;
  }

  // State.
  without_target_ = chosen >= 0 || progress_.waiting ? 0 : without_target_ + 1;
  const int open_regions =
      static_cast<int>(frontiers.regions.size()) + progress_.unmapped_walls;
  if (blocked_streak_ >= options_.stuck_decisions) {
    progress_.state = ExplorationState::kStuck;
    progress_.reason = absl::StrCat("no collision-free control for ", blocked_streak_,
                                    " decisions in a row");
  } else if (chosen >= 0 || without_target_ < options_.done_decisions) {
    progress_.state = ExplorationState::kExploring;
    progress_.reason = chosen >= 0           ? ""
                       : progress_.waiting ? "waiting: the targets left are claimed by nearer robots"
                                           : "no target this decision: looking around";
  } else if (open_regions > 0 && stalled_regions_ == open_regions) {
    // Every region left was given up because the robot never got closer to it, though a path
    // led there: exploring is not over, the robot cannot go on (STUCK, as goal_layer.h says;
    // DONE would report the unexplored rest as explored).
    progress_.state = ExplorationState::kStuck;
    progress_.reason = absl::StrCat("no progress: the robot never got closer to the ",
                                    open_regions, " open region(s) left, all given up");
  } else if (open_regions == 0) {
    progress_.state = ExplorationState::kDone;
    progress_.reason = nearest_only_
                           ? "no frontier left: the known free space is closed by walls"
                           : "no open boundary left: the known free space is closed by mapped walls";
  } else {
    progress_.state = ExplorationState::kDone;
    progress_.reason = absl::StrCat(
        "no reachable open boundary left (", open_regions, " open region(s) remain: ",
        progress_.unreachable,
        " that no path through mapped free space reaches or that no reachable place sees; targets "
        "given up: ",
        progress_.given_up - static_cast<int>(stalled_.size()), " still open once looked at, ",
        stalled_.size(), " never got closer to)");
  }
  return progress_;
}

}  // namespace waymark::laser_slam
