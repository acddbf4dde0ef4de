#include "client/robot/laser_session.h"

namespace waymark::cli {

v1::CreateSessionRequest LaserSessionRequest(const adapters::LaserLayout& layout,
                                             const std::string& robot_id, const std::string& name,
                                             v1::ExplorationConfig::Mode mode) {
  v1::CreateSessionRequest request;
  request.set_robot_id(robot_id);
  request.set_name(name);
  v1::LaserSlamConfig* config = request.mutable_laser();
  config->mutable_laser()->set_angle_min(layout.angle_min);
  config->mutable_laser()->set_angle_increment(layout.angle_increment);
  config->mutable_laser()->set_beam_count(layout.beam_count);
  config->mutable_laser()->set_no_return_range(layout.no_return_range);
  *config->mutable_laser_pose() = ToProto(layout.mount);
  config->mutable_exploration()->set_mode(mode);
  return request;
}

}  // namespace waymark::cli
