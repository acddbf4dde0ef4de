// Several robots exploring one map (issue 38, server/laser_slam/exploration/shared_exploration.h):
// the goal layer given another robot's exploration. A frontier the other robot's grid already
// closed is no target, and the map is DONE for this robot once what the two know together is
// closed; a target near one the other robot claimed goes to whichever robot is nearer to it, and a
// robot whose every target is so claimed waits.

#include "server/laser_slam/exploration/shared_exploration.h"

#include <cmath>
#include <memory>
#include <vector>

#include <gtest/gtest.h>

#include "server/laser_slam/exploration/goal_layer.h"
#include "server/laser_slam/geometry.h"
#include "tests/laser_slam/synthetic_scan.h"

namespace waymark::laser_slam {
namespace {

using testing::CastScan;
using testing::Lms200OneDegreeGeometry;
using testing::RayCastOptions;
using testing::SegmentsOf;
using testing::Wall;

Wall Line(double x1, double y1, double x2, double y2) {
  return Wall{Eigen::Vector2d(x1, y1), Eigen::Vector2d(x2, y2)};
}

ExplorationView ViewAt(const std::vector<Wall>& walls, const Pose2& pose,
                       std::vector<Teammate> teammates = {}) {
  ExplorationView view;
  view.robot = pose;
  view.scan = CastScan(walls, pose, Lms200OneDegreeGeometry(), RayCastOptions{}, nullptr);
  view.segments = SegmentsOf(walls);
  view.teammates = std::move(teammates);
  return view;
}

// Two 4 x 4 m rooms side by side (x 0..4 and 4..8), joined by a 1.2 m doorway at y 1.4..2.6.
std::vector<Wall> TwoRooms() {
  return {Line(0, 0, 8, 0),   Line(8, 0, 8, 4),     Line(8, 4, 0, 4),
          Line(0, 4, 0, 0),   Line(4, 0, 4, 1.4),   Line(4, 2.6, 4, 4)};
}

// What a robot standing at `at` and looking all round knows: its own exploration grid.
std::shared_ptr<ExplorationSnapshot> SnapshotAt(const std::vector<Wall>& walls,
                                                const Eigen::Vector2d& at,
                                                std::optional<Eigen::Vector2d> claim = {}) {
  const ExplorationOptions options;
  ExplorationGoals goals(options, /*nearest_only=*/false);
  for (double heading : {0.0, M_PI / 2, M_PI, -M_PI / 2}) {
    goals.Update(ViewAt(walls, Pose2{at.x(), at.y(), heading}), false);
  }
  auto snapshot = std::make_shared<ExplorationSnapshot>();
  snapshot->grid = goals.own_grid();
  snapshot->segments = SegmentsOf(walls);
  snapshot->robot = Pose2{at.x(), at.y(), 0.0};
  snapshot->stood = goals.stood();
  snapshot->claim = claim;
  return snapshot;
}

// Turns on the spot at `at` for `decisions` decisions (`turn` each).
const GoalProgress& LookAround(ExplorationGoals* goals, const std::vector<Wall>& walls,
                               const Eigen::Vector2d& at, const std::vector<Teammate>& mates,
                               int decisions, double turn = M_PI / 2) {
  for (int i = 0; i < decisions; ++i) {
    goals->Update(ViewAt(walls, Pose2{at.x(), at.y(), i * turn}, mates), false);
  }
  return goals->progress();
}

TEST(SharedExplorationTest, AFrontierAnotherRobotClosedIsNoTargetAndTheRobotIsDone) {
  const ExplorationOptions options;
  const Eigen::Vector2d here(2.0, 2.0);
  // Alone, the west room's robot sees the east room through the doorway and goes there.
  ExplorationGoals alone(options, /*nearest_only=*/false);
  const GoalProgress& a = LookAround(&alone, TwoRooms(), here, {}, 8);
  EXPECT_EQ(a.state, ExplorationState::kExploring);
  ASSERT_TRUE(a.target.has_value());
  EXPECT_GT(a.target->look_at.x(), 4.0) << a.target->look_at.transpose();

  // Another robot has looked round the east room (its frame: the world shifted by (-6, -2) and
  // turned a quarter; to_here takes it back).
  const Pose2 to_here{6.0, 2.0, M_PI / 2};
  std::vector<Wall> in_its_frame;
  const Pose2 from_here = Invert(to_here);
  for (const Wall& w : TwoRooms()) {
    const Pose2 a2 = Compose(from_here, Pose2{w.a.x(), w.a.y(), 0});
    const Pose2 b2 = Compose(from_here, Pose2{w.b.x(), w.b.y(), 0});
    in_its_frame.push_back(Line(a2.x, a2.y, b2.x, b2.y));
  }
  auto east = SnapshotAt(in_its_frame, Eigen::Vector2d(0.0, 0.0));
  ExplorationGoals together(options, /*nearest_only=*/false);
  const GoalProgress& t =
      LookAround(&together, TwoRooms(), here, {Teammate{east, to_here}}, 8);
  EXPECT_FALSE(t.target.has_value()) << t.target->look_at.transpose();
  EXPECT_EQ(t.targets_left, 0);
  EXPECT_EQ(t.state, ExplorationState::kDone) << t.reason;
  // Its own grid is still only what it saw itself: the teammate's knowledge is merged per
  // decision, not integrated.
  EXPECT_GT(together.grid().KnownArea(), together.own_grid().KnownArea() + 5.0);
}

TEST(SharedExplorationTest, ATargetANearerRobotClaimedIsLeftToIt) {
  const ExplorationOptions options;
  // A corridor 2 m wide running far beyond the laser both ways: a frontier at each end, 6 m off.
  const std::vector<Wall> corridor = {Line(-30, -1, 30, -1), Line(-30, 1, 30, 1)};
  const Eigen::Vector2d here(0.0, 0.0);
  ExplorationGoals alone(options, /*nearest_only=*/false);
  const GoalProgress& a = LookAround(&alone, corridor, here, {}, 2, M_PI);
  ASSERT_TRUE(a.target.has_value());
  const Eigen::Vector2d chosen = a.target->look_at;
  ASSERT_GT(std::abs(chosen.x()), 5.0) << "a frontier at an end of the corridor";
  const double side = chosen.x() > 0 ? 1.0 : -1.0;

  // Another robot, nearer to that end, claimed it: this robot takes the other end.
  auto mate = std::make_shared<ExplorationSnapshot>();
  mate->robot = Pose2{side * 3.0, 0.0, 0.0};
  mate->claim = chosen;
  ExplorationGoals yielding(options, /*nearest_only=*/false);
  const GoalProgress& y =
      LookAround(&yielding, corridor, here, {Teammate{mate, Pose2{}}}, 2, M_PI);
  ASSERT_TRUE(y.target.has_value());
  EXPECT_LT(y.target->look_at.x() * side, -5.0) << y.target->look_at.transpose();

  // The same claim by a robot farther from it than this one: this robot keeps it.
  mate->robot = Pose2{-side * 3.0, 0.0, 0.0};
  ExplorationGoals keeping(options, /*nearest_only=*/false);
  const GoalProgress& k = LookAround(&keeping, corridor, here, {Teammate{mate, Pose2{}}}, 2, M_PI);
  ASSERT_TRUE(k.target.has_value());
  EXPECT_GT(k.target->look_at.x() * side, 0.0) << k.target->look_at.transpose();

  // Both ends claimed by nearer robots: this robot waits, exploring (not DONE), with no target
  // and so no claim of its own.
  auto west = std::make_shared<ExplorationSnapshot>();
  west->robot = Pose2{-side * 3.0, 0.0, 0.0};
  west->claim = Eigen::Vector2d(-chosen.x(), chosen.y());
  mate->robot = Pose2{side * 3.0, 0.0, 0.0};
  ExplorationGoals waiting(options, /*nearest_only=*/false);
  const GoalProgress& w = LookAround(
      &waiting, corridor, here, {Teammate{mate, Pose2{}}, Teammate{west, Pose2{}}}, 6, M_PI);
  EXPECT_TRUE(w.waiting);
  EXPECT_FALSE(w.target.has_value());
  EXPECT_EQ(w.state, ExplorationState::kExploring) << w.reason;
  EXPECT_GE(w.targets_left, 2);

  // A finished robot claims nothing.
  mate->robot = Pose2{side * 3.0, 0.0, 0.0};
  mate->finished = true;
  ExplorationGoals after(options, /*nearest_only=*/false);
  const GoalProgress& f = LookAround(&after, corridor, here, {Teammate{mate, Pose2{}}}, 2, M_PI);
  ASSERT_TRUE(f.target.has_value());
  EXPECT_GT(f.target->look_at.x() * side, 0.0);
}

TEST(SharedExplorationTest, WhereATeammateStoodIsFreeAndItsUnknownCellsFillOnlyUnknownOnes) {
  ExplorationGrid mine(0.1);
  mine.Set(Eigen::Vector2d(1.05, 1.05), GridCell::kOccupied);  // another robot, seen as a blob
  mine.Set(Eigen::Vector2d(2.05, 1.05), GridCell::kFree);
  auto mate = std::make_shared<ExplorationSnapshot>();
  mate->grid.Set(Eigen::Vector2d(2.05, 1.05), GridCell::kOccupied);  // disagrees: mine wins
  mate->grid.Set(Eigen::Vector2d(3.05, 1.05), GridCell::kOccupied);  // unknown to me: taken
  mate->stood = {Eigen::Vector2d(1.0, 1.0)};
  ExplorationGrid merged = mine;
  MergeTeammates({Teammate{mate, Pose2{}}}, 0.3, &merged);
  auto at = [&](double x, double y) {
    const Eigen::Vector2i c = merged.CellOf(Eigen::Vector2d(x, y));
    return merged.At(c.x(), c.y());
  };
  EXPECT_EQ(at(1.05, 1.05), GridCell::kFree);
  EXPECT_EQ(at(2.05, 1.05), GridCell::kFree);
  EXPECT_EQ(at(3.05, 1.05), GridCell::kOccupied);
  EXPECT_EQ(at(5.05, 1.05), GridCell::kUnknown);
}

}  // namespace
}  // namespace waymark::laser_slam
