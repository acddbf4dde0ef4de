// Exploration metrics: map completeness against the true walls (all of them, and those that can
// be seen) and the frames that put the SLAM map and the odometry into the world.
#include "client/eval/exploration_metrics.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "client/eval/relations_metric.h"  // Inverse

namespace waymark::cli {
namespace {

using adapters::Wall;

// A 10 m corridor: two parallel walls 2 m apart.
std::vector<Wall> Corridor() { return {{0, 0, 10, 0}, {0, 2, 10, 2}}; }

std::vector<SceneSegment> AsMap(const std::vector<Wall>& walls, double dx = 0, double dy = 0) {
  std::vector<SceneSegment> map;
  for (const Wall& w : walls) map.push_back({{w.x1 + dx, w.y1 + dy}, {w.x2 + dx, w.y2 + dy}});
  return map;
}

TEST(ExplorationCompleteness, MapEqualToTheWallsIsComplete) {
  EXPECT_DOUBLE_EQ(Completeness(Corridor(), AsMap(Corridor())), 1.0);
  const std::vector<Wall> room = {{0, 0, 4, 0}, {4, 0, 4, 3}, {4, 3, 0, 3}, {0, 3, 0, 0}};
  EXPECT_DOUBLE_EQ(Completeness(room, AsMap(room)), 1.0);
}

TEST(ExplorationCompleteness, HalfTheWallsIsAboutHalf) {
  // The first half of each wall; the 0.1 m tolerance reaches 0.1 m past each half's end.
  const std::vector<Wall> halves = {{0, 0, 5, 0}, {0, 2, 5, 2}};
  const double completeness = Completeness(Corridor(), AsMap(halves));
  EXPECT_NEAR(completeness, 0.51, 0.005);
}

TEST(ExplorationCompleteness, MapOffsetBeyondTheToleranceCoversNothing) {
  EXPECT_DOUBLE_EQ(Completeness(Corridor(), AsMap(Corridor(), 0, 0.2)), 0.0);
  EXPECT_DOUBLE_EQ(Completeness(Corridor(), AsMap(Corridor(), 0, -0.11)), 0.0);
  // (A closed room shifted sideways is no such case: its shifted walls cross the true ones.)
  // Within the tolerance it is all covered.
  EXPECT_DOUBLE_EQ(Completeness(Corridor(), AsMap(Corridor(), 0, 0.09)), 1.0);
}

TEST(ExplorationCompleteness, EmptyAndNonFiniteInputs) {
  EXPECT_DOUBLE_EQ(Completeness({}, AsMap(Corridor())), 0.0);
  EXPECT_DOUBLE_EQ(Completeness(Corridor(), {}), 0.0);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_DOUBLE_EQ(Completeness(Corridor(), {{{nan, 0}, {10, 0}}}), 0.0);
}

// A 4 m x 3 m room with a 1 m wide cabinet (three walls) flush against its south wall: the 1 m of
// wall behind the cabinet is never seen.
adapters::World RoomWithCabinet() {
  absl::StatusOr<adapters::World> world = adapters::ParseWorld(
      "start 2 1.5 0\n"
      "wall 0 0 4 0\nwall 4 0 4 3\nwall 4 3 0 3\nwall 0 3 0 0\n"
      "wall 1.5 0 1.5 0.5\nwall 1.5 0.5 2.5 0.5\nwall 2.5 0.5 2.5 0\n");
  EXPECT_TRUE(world.ok()) << world.status();
  return world.ok() ? *std::move(world) : adapters::World{};
}

TEST(ExplorationCompletenessOfVisible, APerfectMapIsCompleteAndSoIsOneOfWhatCanBeSeen) {
  const adapters::World room = RoomWithCabinet();
  const std::vector<adapters::WallSample> visible = adapters::VisibleWalls(room);
  EXPECT_NEAR(adapters::SampleLength(visible), room.WallLength() - 1, 1e-9);
  EXPECT_DOUBLE_EQ(CompletenessOfVisible(visible, AsMap(room.walls)), 1.0);
  // Everything but the wall behind the cabinet: all that can be seen, not all there is.
  std::vector<Wall> seen = room.walls;
  seen[0] = {0, 0, 1.5, 0};
  seen.push_back({2.5, 0, 4, 0});
  EXPECT_DOUBLE_EQ(CompletenessOfVisible(visible, AsMap(seen)), 1.0);
  // (The cabinet's sides cover 0.1 m of the hidden metre at each end.)
  EXPECT_NEAR(Completeness(room.walls, AsMap(seen)), (room.WallLength() - 0.8) / room.WallLength(),
              0.002);
}

TEST(ExplorationCompletenessOfVisible, PartsAndNothing) {
  const adapters::World room = RoomWithCabinet();
  const std::vector<adapters::WallSample> visible = adapters::VisibleWalls(room);
  // The north wall alone: 4 m of the 15 m that can be seen, and 0.1 m of each side wall.
  EXPECT_NEAR(CompletenessOfVisible(visible, AsMap({room.walls[2]})), 4.2 / 15, 1e-9);
  EXPECT_DOUBLE_EQ(CompletenessOfVisible(visible, {}), 0.0);
  EXPECT_DOUBLE_EQ(CompletenessOfVisible({}, AsMap(room.walls)), 0.0);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  EXPECT_DOUBLE_EQ(CompletenessOfVisible(visible, {{{nan, 3}, {4, 3}}}), 0.0);
}

TEST(ExplorationCompleteness, PointSegmentDistance) {
  EXPECT_DOUBLE_EQ(PointSegmentDistance({5, 1}, {0, 0}, {10, 0}), 1.0);
  EXPECT_DOUBLE_EQ(PointSegmentDistance({13, 4}, {0, 0}, {10, 0}), 5.0);  // past the end
  EXPECT_DOUBLE_EQ(PointSegmentDistance({3, 4}, {0, 0}, {0, 0}), 5.0);    // a point
}

TEST(ExplorationFrames, MapFrameIsTheRobotAtTheFirstScan) {
  const FrameTransform t = FrameTransform::MapToWorld({2, 3, M_PI / 2});
  const Pose2 p = t.Apply(Pose2{1, 0, 0});  // 1 m ahead of the first pose
  EXPECT_NEAR(p.x, 2, 1e-12);
  EXPECT_NEAR(p.y, 4, 1e-12);
  EXPECT_NEAR(p.theta, M_PI / 2, 1e-12);
  const SceneSegment s = t.Apply(SceneSegment{{0, 0}, {0, 1}, true, false});
  EXPECT_NEAR(s.a.x, 2, 1e-12);
  EXPECT_NEAR(s.b.x, 1, 1e-12);
  EXPECT_NEAR(s.b.y, 3, 1e-12);
  EXPECT_TRUE(s.a_real);
  EXPECT_FALSE(s.b_real);
}

TEST(ExplorationFrames, OdometryIsAnchoredAtTheFirstScan) {
  const Pose2 truth0{1, 1, M_PI / 2}, odom0{5, 5, 0};
  const FrameTransform t = FrameTransform::OdometryToWorld(truth0, odom0);
  const Pose2 at0 = t.Apply(odom0);
  EXPECT_NEAR(at0.x, 1, 1e-12);
  EXPECT_NEAR(at0.y, 1, 1e-12);
  EXPECT_NEAR(at0.theta, M_PI / 2, 1e-12);
  // 1 m forward in odometry is 1 m forward of the true start.
  const Pose2 later = t.Apply(Pose2{6, 5, 0});
  EXPECT_NEAR(later.x, 1, 1e-12);
  EXPECT_NEAR(later.y, 2, 1e-12);
  EXPECT_NEAR(PositionError(later, {1, 2.5, 0}), 0.5, 1e-12);
}

TEST(ExplorationFrames, ACompleteMapSeenFromTheFirstPoseIsCompleteInTheWorld) {
  const Pose2 first{3, 1, 0.7};
  const FrameTransform to_world = FrameTransform::MapToWorld(first);
  const FrameTransform to_map = FrameTransform::MapToWorld(Inverse(first));
  std::vector<SceneSegment> map_frame;
  for (const SceneSegment& s : AsMap(Corridor())) map_frame.push_back(to_map.Apply(s));
  std::vector<SceneSegment> world;
  for (const SceneSegment& s : map_frame) world.push_back(to_world.Apply(s));
  EXPECT_DOUBLE_EQ(Completeness(Corridor(), world), 1.0);
  EXPECT_LT(Completeness(Corridor(), map_frame), 0.5);
}

}  // namespace
}  // namespace waymark::cli
