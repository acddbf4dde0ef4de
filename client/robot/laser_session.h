#ifndef WAYMARK_CLIENT_ROBOT_LASER_SESSION_H_
#define WAYMARK_CLIENT_ROBOT_LASER_SESSION_H_

// What every laser client sends the SLAM service the same way: the CreateSession request for a
// laser's beam layout and mount, and poses in wire form.

#include <string>

#include "client/devices/robot_devices.h"
#include "waymark/v1/slam.pb.h"

namespace waymark::cli {

// Any pose with x, y and theta members (BasePose, CarmenPose) in wire form.
template <typename Pose>
v1::Pose2D ToProto(const Pose& pose) {
  v1::Pose2D out;
  out.set_x(pose.x);
  out.set_y(pose.y);
  out.set_theta(pose.theta);
  return out;
}

v1::CreateSessionRequest LaserSessionRequest(const adapters::LaserLayout& layout,
                                             const std::string& robot_id, const std::string& name,
                                             v1::ExplorationConfig::Mode mode);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_ROBOT_LASER_SESSION_H_
