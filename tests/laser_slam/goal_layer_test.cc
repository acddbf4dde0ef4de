// The goal layer above the exploration planner (issue 17, server/laser_slam/exploration/
// goal_layer.h) on ray-cast scans of hand-made worlds: DONE in a closed room, unmapped walls,
// the target at a side opening and its path, an opening too narrow to reach, STUCK when the
// robot never gets closer, FRONTIER's nearest target against ACTIVE's utility; the planner
// following its paths with collision-free controls and finishing; and a closed loop through a
// LaserSlam session that explores two rooms until DONE. goal_layer_grid_test.cc tests the grid,
// frontiers and paths it is built on.

#include "server/laser_slam/exploration/goal_layer.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include "server/laser_slam/exploration/clearance.h"
#include "server/laser_slam/exploration/exploration_planner.h"
#include "server/laser_slam/geometry.h"
#include "server/laser_slam/motion.h"
#include "tests/laser_slam/engine_loop.h"
#include "tests/laser_slam/synthetic_scan.h"

namespace waymark::laser_slam {
namespace {

using ::testing::HasSubstr;
using testing::Box;
using testing::CastScan;
using testing::DistanceToWalls;
using testing::EngineLoop;
using testing::Lms200OneDegreeGeometry;
using testing::RayCastOptions;
using testing::SegmentsOf;
using testing::W;
using testing::Wall;

// ---------------------------------------------------------------------------------------------
// Helpers: worlds of walls and the views the robot has of them.

Eigen::Vector2d At(const Pose2& pose) { return Eigen::Vector2d(pose.x, pose.y); }

// The robot at `pose` (laser at its centre) after one noise-free 1-degree LMS200 scan of `walls`,
// with all the walls in its segment map.
ExplorationView ViewAt(const std::vector<Wall>& walls, const Pose2& pose) {
  ExplorationView view;
  view.robot = pose;
  view.scan = CastScan(walls, pose, Lms200OneDegreeGeometry(), RayCastOptions{}, nullptr);
  view.segments = SegmentsOf(walls);
  return view;
}

// A 4 x 4 m room; the robot stands in its middle.
std::vector<Wall> Room() { return Box(0, 0, 4, 4); }
const Pose2 kRoomCentre{2.0, 2.0, 0.0};

// A 2 m wide corridor along +x, closed at x = -3 and x = 5 (both within the laser's 6 m of the
// robot at the origin), with a 1.2 m opening in its left wall (x in [2.4, 3.6]) into a side
// corridor going up. The walls are off the 0.1 m lattice, as real walls are.
std::vector<Wall> CorridorWithSideOpening() {
  return {W(-3, -0.97, 5, -0.97), W(5, -0.97, 5, 1.03),  W(3.6, 1.03, 5, 1.03),
          W(-3, 1.03, 2.4, 1.03), W(2.4, 1.03, 2.4, 7),  W(3.6, 1.03, 3.6, 7),
          W(-3, -0.97, -3, 1.03)};
}
bool InSideOpening(const Eigen::Vector2d& p) {
  return p.x() >= 2.4 && p.x() <= 3.6 && p.y() >= 0.9 && p.y() <= 1.6;
}

// The corridor seen both ways from the origin: looking ahead, then back (so that nothing behind
// the robot is left open: the laser sees the half plane ahead only).
void LookBothWays(ExplorationGoals* goals, const std::vector<Wall>& walls, const Pose2& at) {
  goals->Update(ViewAt(walls, Pose2{at.x, at.y, 0.0}), false);
  goals->Update(ViewAt(walls, Pose2{at.x, at.y, M_PI}), false);
}

// ---------------------------------------------------------------------------------------------
// The goal layer on ray-cast scans of hand-made worlds.

// Turns on the spot in the room's middle until the grid is closed all round, then stands: DONE
// must come exactly when done_decisions decisions in a row had no target.
TEST(GoalLayerTest, ClosedRoomSeenAllRoundIsDone) {
  const ExplorationOptions options;
  ExplorationGoals goals(options, /*nearest_only=*/false);
  const GoalProgress& first = goals.Update(ViewAt(Room(), kRoomCentre), false);
  EXPECT_EQ(first.state, ExplorationState::kExploring);
  ASSERT_TRUE(first.target.has_value()) << "the half behind the robot is still unseen";
  int without_target = 0;
  for (double heading : {M_PI / 2, M_PI, -M_PI / 2, 0.0, 0.0, 0.0, 0.0}) {
    const GoalProgress& p =
        goals.Update(ViewAt(Room(), Pose2{kRoomCentre.x, kRoomCentre.y, heading}), false);
    without_target = p.target ? 0 : without_target + 1;
    EXPECT_EQ(p.state == ExplorationState::kDone, without_target >= options.done_decisions)
        << "heading " << heading << ": " << p.reason;
  }
  const GoalProgress& p = goals.progress();
  EXPECT_EQ(p.state, ExplorationState::kDone);
  EXPECT_THAT(p.reason, HasSubstr("no open boundary left"));
  EXPECT_EQ(p.targets_left, 0);
  EXPECT_EQ(p.unmapped_walls, 0);
  EXPECT_EQ(p.open_share, 0.0);
  EXPECT_NEAR(p.known_area, 16.0, 2.0);  // the room, its walls' cells included
}

// ACTIVE also targets walls the segment map lacks: the same room seen all round with an empty
// segment map is not done, while FRONTIER mode (which knows no segments) is.
TEST(GoalLayerTest, WallsMissingFromTheSegmentMapKeepActiveModeExploring) {
  const ExplorationOptions options;
  ExplorationGoals active(options, /*nearest_only=*/false);
  ExplorationGoals frontier(options, /*nearest_only=*/true);
  for (int round = 0; round < 2; ++round) {
    for (double heading : {0.0, M_PI / 2, M_PI, -M_PI / 2}) {
      ExplorationView view = ViewAt(Room(), Pose2{kRoomCentre.x, kRoomCentre.y, heading});
      view.segments.clear();
      active.Update(view, false);
      frontier.Update(view, false);
    }
  }
  EXPECT_EQ(frontier.progress().state, ExplorationState::kDone);
  EXPECT_EQ(active.progress().state, ExplorationState::kExploring);
  ASSERT_TRUE(active.progress().target.has_value());
  EXPECT_EQ(active.progress().target->kind, TargetKind::kWall);
  EXPECT_GT(active.progress().unmapped_walls, 0);
  EXPECT_GT(active.progress().open_share, 0.5);
}

TEST(GoalLayerTest, SideOpeningIsTheTargetAndItsPathKeepsClearOfWalls) {
  const ExplorationOptions options;
  const double required = options.robot_radius + options.clearance;
  for (bool nearest_only : {true, false}) {
    SCOPED_TRACE(nearest_only ? "FRONTIER" : "ACTIVE");
    ExplorationGoals goals(options, nearest_only);
    LookBothWays(&goals, CorridorWithSideOpening(), Pose2{});
    const GoalProgress& p = goals.progress();
    EXPECT_EQ(p.state, ExplorationState::kExploring);
    EXPECT_EQ(p.targets_left, 1);
    ASSERT_TRUE(p.target.has_value());
    EXPECT_EQ(p.target->kind, TargetKind::kFrontier);
    EXPECT_TRUE(InSideOpening(p.target->look_at)) << p.target->look_at.transpose();
    ASSERT_GE(p.path.size(), 2u);
    EXPECT_LT(p.path.front().norm(), 0.1) << "the path starts in the robot's cell";
    EXPECT_LT((p.path.back() - p.target->goal).norm(), 1e-9);
    for (const Eigen::Vector2d& q : p.path) {
      EXPECT_GE(DistanceToWalls(CorridorWithSideOpening(), q), required) << q.transpose();
    }
  }
}

// The same corridor with a 0.8 m opening, narrower than the robot's disc and clearance (0.9 m).
std::vector<Wall> CorridorWithNarrowOpening() {
  return {W(-3, -0.97, 5, -0.97), W(5, -0.97, 5, 1.03),  W(3.4, 1.03, 5, 1.03),
          W(-3, 1.03, 2.6, 1.03), W(2.6, 1.03, 2.6, 7),  W(3.4, 1.03, 3.4, 7),
          W(-3, -0.97, -3, 1.03)};
}

// Once the robot has looked up the narrow side corridor, what is left open lies up there, where
// it does not fit: no target, and DONE says open boundary remains that no path reaches.
TEST(GoalLayerTest, FrontierBeyondANarrowOpeningIsUnreachableAndDoneSaysSo) {
  const ExplorationOptions options;
  ExplorationGoals goals(options, /*nearest_only=*/true);
  LookBothWays(&goals, CorridorWithNarrowOpening(), Pose2{});
  for (int i = 0; i < options.done_decisions; ++i) {
    goals.Update(ViewAt(CorridorWithNarrowOpening(), Pose2{3.0, 0.0, M_PI / 2}), false);
  }
  const GoalProgress& p = goals.progress();
  EXPECT_FALSE(p.target.has_value());
  EXPECT_EQ(p.targets_left, 0);
  EXPECT_GE(p.unreachable, 1);
  EXPECT_GT(p.open_share, 0.0);
  EXPECT_EQ(p.state, ExplorationState::kDone);
  EXPECT_THAT(p.reason, HasSubstr("no reachable open boundary left"));
}

// A robot that never gets closer to the one open region left (here it does not move at all)
// gives its target up after no_progress_decisions decisions. The region is still there and a
// path reaches it: that is STUCK (goal_layer.h, the proto's "no progress"), not DONE.
TEST(GoalLayerTest, OpenRegionGivenUpForLackOfProgressIsStuckNotDone) {
  const ExplorationOptions options;
  ExplorationGoals goals(options, /*nearest_only=*/true);
  LookBothWays(&goals, CorridorWithSideOpening(), Pose2{});
  ASSERT_TRUE(goals.progress().target.has_value());
  for (int i = 0; i < options.no_progress_decisions + options.done_decisions; ++i) {
    goals.Update(ViewAt(CorridorWithSideOpening(), Pose2{}), false);
  }
  const GoalProgress& p = goals.progress();
  EXPECT_EQ(p.given_up, 1);
  EXPECT_EQ(p.unreachable, 0);
  EXPECT_EQ(p.state, ExplorationState::kStuck) << p.reason;
  EXPECT_THAT(p.reason, HasSubstr("never got closer"));
}

// A corridor with a narrow side opening near the robot (a little frontier) that opens at its end
// into a hall beyond the laser's range (a long one): FRONTIER mode goes to the nearest, ACTIVE
// weighs the gain and goes to the hall.
std::vector<Wall> CorridorIntoAHall() {
  return {W(-3, -0.97, 3.4, -0.97), W(-3, -0.97, -3, 1.03),  W(-3, 1.03, 1.0, 1.03),
          W(1.0, 1.03, 1.0, 7),     W(1.9, 1.03, 1.9, 7),    W(1.9, 1.03, 3.4, 1.03),
          W(3.4, 1.03, 3.4, 10),    W(3.4, -0.97, 3.4, -10)};
}

// The utility trades gain against travel: at a low travel cost the larger, farther frontier wins;
// at a high one ACTIVE takes the near one too.
TEST(GoalLayerTest, NearestOnlyTakesTheNearFrontierActiveTheLargerOne) {
  ExplorationOptions options;
  options.travel_cost = 0.1;
  ExplorationGoals nearest(options, /*nearest_only=*/true);
  ExplorationGoals active(options, /*nearest_only=*/false);
  LookBothWays(&nearest, CorridorIntoAHall(), Pose2{-1.0, 0.0, 0.0});
  LookBothWays(&active, CorridorIntoAHall(), Pose2{-1.0, 0.0, 0.0});
  ASSERT_TRUE(nearest.progress().target && active.progress().target);
  EXPECT_EQ(nearest.progress().targets_left, 2);
  EXPECT_EQ(active.progress().targets_left, 2);
  const ExplorationTarget& n = *nearest.progress().target;
  const ExplorationTarget& a = *active.progress().target;
  EXPECT_TRUE(n.look_at.x() > 1.0 && n.look_at.x() < 1.9 && n.look_at.y() > 0.9)
      << "nearest: the side opening, got " << n.look_at.transpose();
  EXPECT_GT(a.look_at.x(), 3.3) << "active: the hall, got " << a.look_at.transpose();
  EXPECT_LT(n.path_length, a.path_length);
  EXPECT_GT(a.gain, 5.0 * n.gain);

  options.travel_cost = 1.0;
  ExplorationGoals thrifty(options, /*nearest_only=*/false);
  LookBothWays(&thrifty, CorridorIntoAHall(), Pose2{-1.0, 0.0, 0.0});
  ASSERT_TRUE(thrifty.progress().target);
  EXPECT_LT((thrifty.progress().target->look_at - n.look_at).norm(), 0.5)
      << "a high travel cost: the near frontier, got "
      << thrifty.progress().target->look_at.transpose();
}

// ---------------------------------------------------------------------------------------------
// The planner with the goal layer.

ExplorationOptions FrontierMode() {
  ExplorationOptions options;
  options.mode = ExplorationMode::kFrontier;
  return options;
}

TEST(GoalPlannerTest, FrontierModeFollowsThePathToTheSideOpening) {
  ExplorationPlanner planner(FrontierMode());
  planner.Decide(ViewAt(CorridorWithSideOpening(), Pose2{0.0, 0.0, M_PI}));
  const ExplorationView view = ViewAt(CorridorWithSideOpening(), Pose2{});
  const Suggestion s = planner.Decide(view);
  EXPECT_EQ(s.behaviour, Behaviour::kToTarget);
  ASSERT_NE(planner.goals(), nullptr);
  ASSERT_TRUE(planner.goals()->progress().target.has_value());
  EXPECT_TRUE(InSideOpening(planner.goals()->progress().target->look_at));
  // The control's arc ends nearer the goal along the path than the robot stands now.
  const Pose2 end = Compose(view.robot, UnicycleArc(s.linear, s.angular, s.duration));
  EXPECT_LT(planner.goals()->CostToGoal(At(end)), planner.goals()->CostToGoal(At(view.robot)));
}

TEST(GoalPlannerTest, InAClosedRoomSeenAllRoundFinishes) {
  ExplorationPlanner planner(FrontierMode());
  for (double heading : {0.0, M_PI / 2, M_PI, -M_PI / 2}) {
    const Suggestion s = planner.Decide(ViewAt(Room(), Pose2{2.0, 2.0, heading}));
    EXPECT_NE(s.behaviour, Behaviour::kFinished) << "finished before the room was seen";
  }
  Suggestion s;
  for (int i = 0; i < FrontierMode().done_decisions && s.behaviour != Behaviour::kFinished; ++i) {
    s = planner.Decide(ViewAt(Room(), kRoomCentre));
  }
  EXPECT_EQ(s.behaviour, Behaviour::kFinished);
  EXPECT_EQ(s.linear, 0.0);
  EXPECT_EQ(s.angular, 0.0);
  EXPECT_EQ(planner.goals()->progress().state, ExplorationState::kDone);
}

// Closed loop without SLAM (the robot moves exactly as told and knows its pose) from the corridor
// into the side opening. Every control the path following picks passes the collision check the
// planner made for that decision (rebuilt here), and some decisions had controls it refused. In
// FRONTIER mode the segment map is empty, so that the check rests on the scan and the grid.
TEST(GoalPlannerTest, PathFollowingPicksCollisionFreeControlsOnly) {
  for (ExplorationMode mode : {ExplorationMode::kFrontier, ExplorationMode::kActive}) {
    SCOPED_TRACE(mode == ExplorationMode::kFrontier ? "FRONTIER" : "ACTIVE");
    ExplorationOptions options;
    options.mode = mode;
    ExplorationPlanner planner(options);
    const double required = options.robot_radius + options.clearance;
    const double reach = options.max_linear * options.observation_period + required + 0.5;
    Pose2 robot{0.0, 0.0, M_PI / 2};
    int followed = 0, constrained = 0;
    for (int i = 0; i < 80 && robot.y < 3.0; ++i) {
      ExplorationView view = ViewAt(CorridorWithSideOpening(), robot);
      if (mode == ExplorationMode::kFrontier) view.segments.clear();
      const Suggestion s = planner.Decide(view);
      ASSERT_EQ(planner.goals()->progress().state, ExplorationState::kExploring);
      if (s.behaviour == Behaviour::kToTarget) {
        const ClearanceMap clearance(view, reach, planner.goals()->OccupiedNear(At(robot), reach));
        EXPECT_TRUE(PathIsFree(clearance, s.linear, s.angular, options.observation_period,
                               options.control_period, required))
            << "decision " << i << " at " << At(robot).transpose();
        ++followed;
        constrained += s.feasible < s.candidates;
      }
      robot = Compose(robot, UnicycleArc(s.linear, s.angular, s.duration));
    }
    EXPECT_GE(robot.y, 3.0) << "never went up the side corridor";
    EXPECT_GT(followed, 10);
    EXPECT_GT(constrained, 0) << "no decision refused a control: the check proved nothing";
  }
}

// ---------------------------------------------------------------------------------------------
// Closed loop through a LaserSlam session (ACTIVE with the goal layer, loop closing on).

// Two 5 x 5 m rooms, a 1.2 m doorway between them (x = 5, y in [1.9, 3.1]).
std::vector<Wall> TwoRooms() {
  return {W(0, 0, 10, 0), W(10, 0, 10, 5), W(10, 5, 0, 5), W(0, 5, 0, 0),
          W(5, 0, 5, 1.9), W(5, 3.1, 5, 5)};
}

TEST(GoalLayerLoopTest, ExploresTwoRoomsUntilDone) {
  SlamOptions options;
  options.exploration.mode = ExplorationMode::kActive;
  ASSERT_TRUE(options.exploration.goal_layer);
  constexpr double kBody = 0.25;
  EngineLoop loop(TwoRooms(), Pose2{1.5, 1.5, M_PI}, options);
  double closest = std::numeric_limits<double>::infinity(), farthest = 0.0;
  GoalProgress last;
  int decisions = 0;
  for (; decisions < 300; ++decisions) {
    const ScanUpdate u = loop.Observe();
    ASSERT_TRUE(u.suggestion.has_value() && u.exploration.has_value());
    last = *u.exploration;
    if (last.state != ExplorationState::kExploring) break;
    closest = std::min(closest, loop.Apply(*u.suggestion));
    farthest = std::max(farthest, loop.truth().x);
  }
  EXPECT_EQ(last.state, ExplorationState::kDone) << last.reason << " after " << decisions;
  EXPECT_GT(closest, kBody) << "the body touched a wall";
  EXPECT_GT(farthest, 5.0 + kBody) << "never went wholly into the second room";
  EXPECT_LT(last.open_share, 0.05);
  EXPECT_GT(last.known_area, 40.0) << "both rooms mapped";
}

}  // namespace
}  // namespace waymark::laser_slam
