// The segment map of a map shared by robots (map_segments.h): a wall two robots mapped becomes
// one segment, walls that only look alike (parallel, or collinear with a doorway between them)
// stay apart, and a trajectory's segments move into the map frame by its origin where they
// were last seen.

#include "server/laser_slam/mapping/map_segments.h"

#include <cmath>
#include <vector>

#include <gtest/gtest.h>

#include "server/laser_slam/geometry.h"

namespace waymark::laser_slam {
namespace {

// A wall from (x0, y0) to (x1, y1), 1 cm and 0.3 degrees (1 sigma) as a filter knows it.
MapSegment Wall(double x0, double y0, double x1, double y1) {
  MapSegment s;
  const double length = std::hypot(x1 - x0, y1 - y0);
  s.frame = Pose2{0.5 * (x0 + x1), 0.5 * (y0 + y1), std::atan2(y1 - y0, x1 - x0)};
  s.left = -0.5 * length;
  s.right = 0.5 * length;
  s.line_covariance = Eigen::Vector2d(1e-4, 3e-5).asDiagonal();
  s.observations = 10;
  return s;
}

// Where the segment's ends lie in the map frame.
Eigen::Vector2d End(const MapSegment& s, bool right) {
  const double along = right ? s.right : s.left;
  return Eigen::Vector2d(s.frame.x + std::cos(s.frame.theta) * along,
                         s.frame.y + std::sin(s.frame.theta) * along);
}

TEST(MapSegmentsTest, AWallTwoRobotsMappedBecomesOneSpanningBoth) {
  // Robot 0 saw x in [0, 6] of the wall y = 2, robot 1 x in [4, 10], 2 cm off and described
  // from its other end.
  const MergedSegments merged = MergeTrajectorySegments(
      {{Wall(0.0, 2.0, 6.0, 2.0), 0}, {Wall(10.0, 2.02, 4.0, 2.02), 1}});
  ASSERT_EQ(merged.segments.size(), 1u);
  EXPECT_EQ(merged.fused, 1);
  EXPECT_EQ(merged.trajectories[0].size(), 2u);
  const MapSegment& wall = merged.segments[0];
  EXPECT_NEAR(wall.right - wall.left, 10.0, 0.01);
  const Eigen::Vector2d a = End(wall, false), b = End(wall, true);
  EXPECT_NEAR(std::min(a.x(), b.x()), 0.0, 0.01);
  EXPECT_NEAR(std::max(a.x(), b.x()), 10.0, 0.01);
  // Between the two sightings, nearer neither more than the other (equal covariances).
  EXPECT_NEAR(0.5 * (a.y() + b.y()), 2.01, 0.005);
  EXPECT_EQ(wall.observations, 20);
  // Fused, it is surer than either.
  EXPECT_LT(wall.line_covariance(0, 0), 1e-4);
}

TEST(MapSegmentsTest, ParallelWallsAndADoorwayStayApart) {
  const MergedSegments merged = MergeTrajectorySegments({
      {Wall(0.0, 2.0, 6.0, 2.0), 0},
      {Wall(0.0, 2.3, 6.0, 2.3), 1},   // the corridor's other side, 30 cm off: another wall
      {Wall(7.0, 2.0, 12.0, 2.0), 1},  // collinear, beyond a 1 m doorway: another wall
      {Wall(2.0, -1.0, 2.0, 1.5), 1},  // across
  });
  EXPECT_EQ(merged.segments.size(), 4u);
  EXPECT_EQ(merged.fused, 0);
}

TEST(MapSegmentsTest, OneTrajectorysOwnSegmentsAreNotFusedAgain) {
  // Its filter kept them two (MergeSegments decides within a session): not undone here.
  const MergedSegments merged = MergeTrajectorySegments(
      {{Wall(0.0, 2.0, 6.0, 2.0), 0}, {Wall(4.0, 2.01, 10.0, 2.01), 0}});
  EXPECT_EQ(merged.segments.size(), 2u);
  // A third robot's view of the same wall joins one of them, not both.
  const MergedSegments three = MergeTrajectorySegments({{Wall(0.0, 2.0, 6.0, 2.0), 0},
                                                        {Wall(4.0, 2.01, 10.0, 2.01), 0},
                                                        {Wall(1.0, 2.0, 9.0, 2.0), 1}});
  EXPECT_EQ(three.segments.size(), 2u);
  EXPECT_EQ(three.fused, 1);
}

TEST(MapSegmentsTest, ASegmentMovesByItsTrajectorysOriginWhereItWasLastSeen) {
  MapSegment wall = Wall(0.0, 0.0, 4.0, 0.0);
  const Pose2 origin{1.0, 2.0, M_PI / 2};
  const MapSegment placed = SegmentInMapFrame(wall, origin, {}, 5.0);
  // (0, 0) -> (1, 2) and (4, 0) -> (1, 6) under the origin.
  EXPECT_NEAR(End(placed, false).x(), 1.0, 1e-9);
  EXPECT_NEAR(End(placed, false).y(), 2.0, 1e-9);
  EXPECT_NEAR(End(placed, true).y(), 6.0, 1e-9);
  // With samples, the origin at the stamp of its last sighting: halfway between two samples.
  std::vector<OriginSample> samples(2);
  samples[0].stamp = 0.0;
  samples[0].origin = Pose2{0.0, 0.0, 0.0};
  samples[1].stamp = 10.0;
  samples[1].origin = Pose2{0.0, 1.0, 0.0};
  const MapSegment followed = SegmentInMapFrame(wall, origin, samples, 5.0);
  EXPECT_NEAR(followed.frame.y, 0.5, 1e-9);
  EXPECT_NEAR(followed.frame.x, 2.0, 1e-9);
}

}  // namespace
}  // namespace waymark::laser_slam
