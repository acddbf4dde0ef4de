// A session's poses moved into its shared map's frame (client/cli/map_frame.h): by the server's
// origins at the session's nodes where it sent them (MapTrajectory.node_origins), else by the
// follow's samples interpolated, else by the one origin.

#include "client/cli/map_frame.h"

#include <gtest/gtest.h>

namespace waymark::cli {
namespace {

v1::MapOriginSample Sample(double stamp, double x, double y) {
  v1::MapOriginSample s;
  s.set_scan(static_cast<uint64_t>(stamp));
  s.set_stamp(stamp);
  s.mutable_origin()->set_x(x);
  s.mutable_origin()->set_y(y);
  return s;
}

// Poses at stamps 1..3, at (stamp, 0) in the session frame, heading 0.
v1::Trajectory Poses() {
  v1::Trajectory t;
  for (int i = 1; i <= 3; ++i) {
    v1::TrajectoryPose* p = t.add_poses();
    p->set_stamp(i);
    p->mutable_pose()->set_x(i);
  }
  return t;
}

TEST(MapFrameTest, TheServersNodeOriginsWinOverTheFollowsSamples) {
  v1::MapTrajectory t;
  t.mutable_origin()->set_x(100.0);
  *t.add_origin_samples() = Sample(1, 10.0, 0.0);
  *t.add_origin_samples() = Sample(3, 30.0, 0.0);
  // The follow's samples alone: interpolated by stamp.
  v1::Trajectory from_samples = Poses();
  MoveToMapFrame(t, &from_samples);
  EXPECT_DOUBLE_EQ(from_samples.poses(1).pose().x(), 2.0 + 20.0);

  for (double stamp : {1.0, 2.0, 3.0}) *t.add_node_origins() = Sample(stamp, -stamp, 1.0);
  v1::Trajectory from_nodes = Poses();
  MoveToMapFrame(t, &from_nodes);
  for (int i = 0; i < 3; ++i) {
    EXPECT_DOUBLE_EQ(from_nodes.poses(i).pose().x(), 0.0) << i;  // (i + 1) - (i + 1)
    EXPECT_DOUBLE_EQ(from_nodes.poses(i).pose().y(), 1.0) << i;
  }

  v1::MapTrajectory fixed;
  fixed.mutable_origin()->set_x(100.0);
  v1::Trajectory from_origin = Poses();
  MoveToMapFrame(fixed, &from_origin);
  EXPECT_DOUBLE_EQ(from_origin.poses(2).pose().x(), 103.0);
}

}  // namespace
}  // namespace waymark::cli
