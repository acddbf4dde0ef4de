#ifndef WAYMARK_TESTS_SERVICE_SLAM_TEST_WORLD_H_
#define WAYMARK_TESTS_SERVICE_SLAM_TEST_WORLD_H_

// A square room and a robot driving in it: noise-free scans and odometry that agree with each
// other, so any SLAM engine (the dead-reckoning placeholder or the EKF) tracks the true pose.
// Header-only, shared by the registry unit tests and the server integration tests.

#include <cmath>
#include <limits>
#include <string>

#include "waymark/v1/slam.pb.h"

namespace waymark::testing {

inline constexpr int kTestBeams = 181;
inline constexpr double kRoomHalfWidth = 4.0;  // walls at x, y = +-4 m

inline v1::LaserGeometry TestGeometry() {
  v1::LaserGeometry g;
  g.set_angle_min(-M_PI / 2);
  g.set_angle_increment(M_PI / 180);
  g.set_beam_count(kTestBeams);
  g.set_no_return_range(8.0);
  return g;
}

inline v1::CreateSessionRequest TestSessionRequest(const std::string& robot) {
  v1::CreateSessionRequest request;
  request.set_robot_id(robot);
  request.set_name("test run of " + robot);
  *request.mutable_laser()->mutable_laser() = TestGeometry();
  return request;
}

// Range from (x, y) along world bearing phi to the room's walls.
inline double RoomRange(double x, double y, double phi) {
  double best = std::numeric_limits<double>::infinity();
  const double c = std::cos(phi), s = std::sin(phi);
  if (c > 1e-9) best = std::min(best, (kRoomHalfWidth - x) / c);
  if (c < -1e-9) best = std::min(best, (-kRoomHalfWidth - x) / c);
  if (s > 1e-9) best = std::min(best, (kRoomHalfWidth - y) / s);
  if (s < -1e-9) best = std::min(best, (-kRoomHalfWidth - y) / s);
  return best;
}

// The scan a laser at the robot's origin sees from pose (x, y, theta).
inline v1::SensorData RoomScan(uint64_t sequence, double stamp, double x, double y, double theta) {
  v1::SensorData data;
  data.set_sequence(sequence);
  v1::LaserScan* scan = data.mutable_scan();
  scan->set_stamp(stamp);
  const v1::LaserGeometry g = TestGeometry();
  for (int i = 0; i < kTestBeams; ++i) {
    const double bearing = g.angle_min() + i * g.angle_increment();
    scan->add_ranges(static_cast<float>(RoomRange(x, y, theta + bearing)));
  }
  return data;
}

inline v1::SensorData Odom(uint64_t sequence, double stamp, double x, double y, double theta) {
  v1::SensorData data;
  data.set_sequence(sequence);
  data.mutable_odometry()->set_stamp(stamp);
  data.mutable_odometry()->mutable_pose()->set_x(x);
  data.mutable_odometry()->mutable_pose()->set_y(y);
  data.mutable_odometry()->mutable_pose()->set_theta(theta);
  return data;
}

}  // namespace waymark::testing

#endif  // WAYMARK_TESTS_SERVICE_SLAM_TEST_WORLD_H_
