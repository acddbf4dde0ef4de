// Active exploration (server/laser_slam/exploration/exploration_planner.h) in constructed situations: the
// predicted observation's extensions and corners, the collision check, the objective's choice at
// a corridor end with a side opening, trap detection in a dead end and wall following out of it,
// wander, and the zero cases of J.

#include "server/laser_slam/exploration/exploration_planner.h"

#include <cmath>
#include <limits>
#include <random>

#include <gtest/gtest.h>

#include "server/laser_slam/exploration/clearance.h"
#include "server/laser_slam/geometry.h"
#include "server/laser_slam/laser_slam.h"
#include "server/laser_slam/motion.h"
#include "server/laser_slam/exploration/observation_prediction.h"
#include "tests/laser_slam/engine_loop.h"
#include "tests/laser_slam/synthetic_scan.h"

namespace waymark::laser_slam {
namespace {

using testing::Box;
using testing::CastScan;
using testing::EngineLoop;
using testing::Lms200OneDegreeGeometry;
using testing::RayCastOptions;
using testing::SegmentBetween;
using testing::W;
using testing::Wall;

// These tests are about the paper's one-step planner: the goal layer above it is off
// (goal_layer_test.cc tests it).
SlamOptions PaperPlanner(ExplorationMode mode) {
  SlamOptions o;
  o.exploration.mode = mode;
  o.exploration.goal_layer = false;
  return o;
}

// The robot at the origin facing -y, where the tests put no map: what it sees from there is the
// predictor's baseline.
ExplorationView EmptyView() {
  ExplorationView view;
  view.robot = Pose2{0.0, 0.0, -M_PI / 2};
  view.robot_covariance = Eigen::Matrix3d::Identity() * 1e-4;
  view.scan.geometry = Lms200OneDegreeGeometry();
  view.scan.ranges.assign(181, 8.183f);
  return view;
}

TEST(ObservationPredictionTest, VirtualEndpointExtendsAsFarAsTheLaserSees) {
  ExplorationView view = EmptyView();
  // A wall along y = 2 mapped over x in [-1, 1], its right end virtual (cut by range, say).
  view.segments = {SegmentBetween(1, -1, 2, 1, 2, EndpointType::kReal, EndpointType::kVirtual)};
  ExplorationOptions options;
  const ObservationPredictor predictor(view, options, 0.0);
  ASSERT_EQ(predictor.frontier_count(), 1);
  // From (1, 0) facing +y the line y = 2 is visible up to the 6 m range: x <= 1 + sqrt(32).
  const ExplorationGain gain = predictor.Predict(Pose2{1.0, 0.0, M_PI / 2});
  EXPECT_NEAR(gain.extension, std::sqrt(32.0), 0.06);
  EXPECT_EQ(gain.new_real_endpoints, 0);
  // Facing away the laser sees nothing of it.
  EXPECT_EQ(predictor.Predict(Pose2{1.0, 0.0, -M_PI / 2}).extension, 0.0);
}

TEST(ObservationPredictionTest, CrossingLineNearTheEndPredictsACorner) {
  ExplorationView view = EmptyView();
  view.segments = {
      SegmentBetween(1, -1, 2, 1, 2, EndpointType::kReal, EndpointType::kVirtual),
      // A wall along x = 1.8 from y = 2.3 up: the two lines meet at (1.8, 2).
      SegmentBetween(2, 1.8, 2.3, 1.8, 4.0, EndpointType::kVirtual, EndpointType::kReal)};
  ExplorationOptions options;
  const ObservationPredictor predictor(view, options, 0.0);
  const ExplorationGain gain = predictor.Predict(Pose2{0.0, 0.0, M_PI / 2});
  // Segment 1 extends 0.8 m to the corner and its end turns real; segment 2's lower end (0.3 m
  // from the corner) also turns real.
  EXPECT_NEAR(gain.extension, 0.8 + 0.3, 0.06);
  EXPECT_EQ(gain.new_real_endpoints, 2);
}

TEST(ObservationPredictionTest, ExtensionHiddenBehindAMappedWallIsNotPredicted) {
  ExplorationView view = EmptyView();
  view.segments = {
      SegmentBetween(1, -1, 2, 1, 2, EndpointType::kReal, EndpointType::kVirtual),
      // A wall between the robot and the line's continuation.
      SegmentBetween(2, 1.05, 1.0, 8.0, 1.0, EndpointType::kReal, EndpointType::kReal)};
  ExplorationOptions options;
  const ObservationPredictor predictor(view, options, 0.0);
  EXPECT_LT(predictor.Predict(Pose2{1.0, 0.0, M_PI / 2}).extension, 0.3);
}

TEST(ClearanceTest, PathIntoAWallIsNotFreeButTurningAwayIs) {
  ExplorationView view = EmptyView();
  view.robot = Pose2{};
  // A wall 0.8 m ahead, seen by the scan.
  const std::vector<Wall> walls = {W(0.8, -3, 0.8, 3)};
  view.scan = CastScan(walls, Pose2{}, Lms200OneDegreeGeometry(), RayCastOptions{}, nullptr);
  const ClearanceMap map(view, 2.0);
  EXPECT_NEAR(map.Distance(Eigen::Vector2d::Zero()), 0.8, 0.01);
  EXPECT_FALSE(PathIsFree(map, 0.15, 0.0, 4.0, 0.1, 0.4));
  EXPECT_TRUE(PathIsFree(map, 0.0, 0.17, 4.0, 0.1, 0.4));
  EXPECT_TRUE(PathIsFree(map, 0.05, 0.0, 4.0, 0.1, 0.4));  // 0.2 m, stays 0.6 m away
  // A mapped wall the scan does not show (here: the scan is empty) also counts.
  ExplorationView side = EmptyView();
  side.robot = Pose2{};
  side.segments = {SegmentBetween(1, -3, 0.5, 3, 0.5, EndpointType::kReal, EndpointType::kReal)};
  const ClearanceMap beside(side, 2.0);
  EXPECT_NEAR(beside.Distance(Eigen::Vector2d::Zero()), 0.5, 1e-9);
  // Already too close: moving parallel to the wall without getting closer is allowed.
  EXPECT_TRUE(PathIsFree(beside, 0.15, 0.0, 4.0, 0.1, 0.6));
  EXPECT_FALSE(PathIsFree(beside, 0.15, 0.17, 4.0, 0.1, 0.6));  // curving into it is not
  EXPECT_TRUE(PathIsFree(beside, 0.15, -0.17, 4.0, 0.1, 0.6));  // curving away is
}

TEST(ExplorationPlannerTest, CandidatesCoverTheGridWithoutStandingStill) {
  ExplorationOptions options;
  options.mode = ExplorationMode::kActive;
  const ExplorationPlanner planner(options);
  const std::vector<Control> candidates = planner.Candidates();
  EXPECT_EQ(candidates.size(), 3u * 7u - 1u);
  EXPECT_DOUBLE_EQ(candidates.front().linear, 0.15);  // fastest, straight ahead first
  EXPECT_DOUBLE_EQ(candidates.front().angular, 0.0);
  for (const Control& c : candidates) {
    EXPECT_FALSE(c.linear == 0.0 && c.angular == 0.0);
    EXPECT_LE(std::abs(c.angular), 0.17 + 1e-12);
  }
}

TEST(ExplorationPlannerTest, EmptyMapHasZeroGainsAndFiniteObjective) {
  ExplorationOptions options;
  options.mode = ExplorationMode::kActive;
  ExplorationPlanner planner(options);
  const ExplorationView view = EmptyView();
  const ObservationPredictor predictor(view, options, 0.6);
  const ControlScore score = planner.Score(view, predictor, Totals(view.segments), Control{0.15, 0});
  EXPECT_EQ(score.j21, 0.0);
  EXPECT_EQ(score.j22, 0.0);
  EXPECT_TRUE(std::isfinite(score.j));
  EXPECT_GT(score.j1, 0.0);
  // Nothing mapped to follow: the planner still moves (wanders) instead of standing.
  for (int i = 0; i < options.trap_decisions + 1; ++i) {
    const Suggestion s = planner.Decide(view);
    EXPECT_GT(std::abs(s.linear) + std::abs(s.angular), 0.0);
    EXPECT_EQ(s.duration, options.observation_period);
  }
}

TEST(ExplorationPlannerTest, J1PrefersTheMotionThatAddsLessUncertainty) {
  ExplorationOptions options;
  options.mode = ExplorationMode::kActive;
  const ExplorationPlanner planner(options);
  const ExplorationView view = EmptyView();
  const ObservationPredictor predictor(view, options, 0.6);
  const MapTotals totals = Totals(view.segments);
  const ControlScore slow = planner.Score(view, predictor, totals, Control{0.075, 0.0});
  const ControlScore fast_turn = planner.Score(view, predictor, totals, Control{0.15, 0.17});
  EXPECT_GT(slow.j1, fast_turn.j1);
  EXPECT_GT(slow.j, fast_turn.j);
}

// A corridor along +x ending in a wall at x = 4, with an opening in its left wall (x in
// [1.5, 3.0]) into a side corridor going up. The robot stands at the origin; it has looked back
// down the corridor (mapped to its closed end at x = -3) and now faces the end.
std::vector<Wall> CorridorEndWithSideOpening() {
  return {W(-3, -1, 4, -1),  W(4, -1, 4, 1),     W(3, 1, 4, 1),  // right wall, end, stub
          W(-3, 1, 1.5, 1),  W(1.5, 1, 1.5, 7),  W(3, 1, 3, 7),  // left wall, side corridor
          W(-3, -1, -3, 1)};
}

TEST(ExplorationPlannerTest, AtACorridorEndTurnsTowardsTheSideOpening) {
  EngineLoop loop(CorridorEndWithSideOpening(), Pose2{0.0, 0.0, M_PI},
                  PaperPlanner(ExplorationMode::kActive));
  loop.Observe();
  Suggestion turn;
  turn.angular = 0.17;
  turn.duration = 3.7;  // 0.629 rad, five times: pi
  for (int i = 0; i < 5; ++i) {
    loop.Apply(turn);
    loop.Observe();
  }
  const ScanUpdate first = loop.Observe();
  ASSERT_NEAR(NormalizeAngle(loop.truth().theta), 0.0, 0.01);
  ASSERT_TRUE(first.suggestion.has_value());
  const Suggestion& s = *first.suggestion;
  EXPECT_EQ(s.behaviour, Behaviour::kOptimal);
  EXPECT_GT(s.score.j21, 0.0) << "the side corridor's wall continues out of view";
  EXPECT_GT(s.angular, 0.0) << "turning left looks into the side corridor";
  EXPECT_GT(s.feasible, 0);
  // Scored directly: the best left turn beats the best right turn.
  ExplorationOptions options = PaperPlanner(ExplorationMode::kActive).exploration;
  const ExplorationPlanner planner(options);
  const ExplorationView view = loop.slam().View();
  const ObservationPredictor predictor(view, options, 0.6);
  const MapTotals totals = Totals(view.segments);
  double best_left = -1e9, best_right = -1e9;
  for (const Control& c : planner.Candidates()) {
    const double j = planner.Score(view, predictor, totals, c).j;
    if (c.angular > 0) best_left = std::max(best_left, j);
    if (c.angular < 0) best_right = std::max(best_right, j);
  }
  EXPECT_GT(best_left, best_right);
}

TEST(ExplorationPlannerTest, DeadEndTriggersWallFollowingWhichLeadsOut) {
  // A 2 m wide dead-end corridor (x in [0, 6]) off a wide hall (x in [-8, 0]); the robot starts
  // near the dead end, facing it.
  const std::vector<Wall> walls = {W(0, -1, 6, -1),  W(0, 1, 6, 1),   W(6, -1, 6, 1),
                                   W(0, 1, 0, 5),    W(0, -1, 0, -5), W(-8, -5, 0, -5),
                                   W(-8, 5, 0, 5),   W(-8, -5, -8, 5)};
  EngineLoop loop(walls, Pose2{4.5, 0.0, 0.0}, PaperPlanner(ExplorationMode::kActive));
  bool followed = false, optimal_after_following = false, left = false;
  double closest = std::numeric_limits<double>::infinity();
  for (int decision = 0; decision < 80 && !(left && optimal_after_following); ++decision) {
    const ScanUpdate u = loop.Observe();
    ASSERT_TRUE(u.suggestion.has_value());
    followed = followed || u.suggestion->behaviour == Behaviour::kWallFollowing;
    optimal_after_following =
        optimal_after_following || (followed && u.suggestion->behaviour == Behaviour::kOptimal);
    closest = std::min(closest, loop.Apply(*u.suggestion));
    left = left || loop.truth().x < -0.5;
  }
  EXPECT_TRUE(followed) << "no trap detected in the dead end";
  EXPECT_TRUE(left) << "still in the dead end at x = " << loop.truth().x;
  EXPECT_TRUE(optimal_after_following) << "never returned to optimal control";
  EXPECT_GT(closest, 0.25) << "the body touched a wall";
}

TEST(ExplorationPlannerTest, WanderDrivesStraightUntilAnObstacleThenTurns) {
  const std::vector<Wall> walls = Box(-3, -3, 3, 3);
  EngineLoop loop(walls, Pose2{-2.0, 0.0, 0.0}, PaperPlanner(ExplorationMode::kWander));
  const ScanUpdate open = loop.Observe();
  ASSERT_TRUE(open.suggestion.has_value());
  EXPECT_EQ(open.suggestion->behaviour, Behaviour::kWander);
  EXPECT_DOUBLE_EQ(open.suggestion->linear, 0.15);
  EXPECT_DOUBLE_EQ(open.suggestion->angular, 0.0);
  double closest = std::numeric_limits<double>::infinity();
  bool turned = false;
  for (int i = 0; i < 40; ++i) {
    const ScanUpdate u = loop.Observe();
    if (u.suggestion->linear == 0.0) {
      turned = true;
      EXPECT_NE(u.suggestion->angular, 0.0);
    }
    closest = std::min(closest, loop.Apply(*u.suggestion));
  }
  EXPECT_TRUE(turned);
  EXPECT_GT(closest, 0.3);
}

TEST(ExplorationPlannerTest, PassiveSessionSuggestsNothing) {
  EngineLoop loop(Box(-3, -3, 3, 3), Pose2{}, PaperPlanner(ExplorationMode::kPassive));
  EXPECT_FALSE(loop.Observe().suggestion.has_value());
}

TEST(ExplorationOptionsTest, RejectsNonsense) {
  ExplorationOptions o;
  EXPECT_TRUE(ValidateExplorationOptions(o).ok());
  o.angular_steps = 4;
  EXPECT_FALSE(ValidateExplorationOptions(o).ok());
  o = ExplorationOptions{};
  o.max_linear = std::nan("");
  EXPECT_FALSE(ValidateExplorationOptions(o).ok());
  o = ExplorationOptions{};
  o.control_period = 5.0;
  EXPECT_FALSE(ValidateExplorationOptions(o).ok());
}

}  // namespace
}  // namespace waymark::laser_slam
