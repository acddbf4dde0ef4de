#ifndef WAYMARK_CLIENT_ROS_BAG_TOPICS_H_
#define WAYMARK_CLIENT_ROS_BAG_TOPICS_H_

// Which topics of a bag a laser replay reads: the sensor_msgs/LaserScan topic, and where the
// odometry comes from (a nav_msgs/Odometry topic, TF, or nothing), plus /tf and /tf_static for the
// laser's mounting. Chosen on their own when the choice is unique; otherwise a precise error that
// lists the candidates and names the flag that chooses (--scan-topic, --odom-topic).

#include <map>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "client/bags/bag_reader.h"
#include "client/ros/ros_wire.h"

namespace waymark::ros {

// --odom-topic values with a meaning of their own.
inline constexpr char kOdomFromTf[] = "tf";      // the odom -> base chain of /tf
inline constexpr char kOdomNone[] = "none";      // no odometry: every scan at the origin

enum class OdometrySource { kOdometryTopic, kTf, kNone };

struct LaserTopics {
  std::string scan_topic;
  OdometrySource odometry = OdometrySource::kNone;
  std::string odom_topic;  // kOdometryTopic only
  std::vector<int> scan_connections;
  std::vector<int> odom_connections;
  std::vector<int> tf_connections;         // /tf (tf2_msgs/TFMessage or tf/tfMessage)
  std::vector<int> tf_static_connections;  // /tf_static
  std::map<int, WireFormat> formats;       // of every connection above
  std::map<int, std::string> types;        // their types, for errors
};

// `scan_topic`, `odom_topic`: the flags, empty when not given. A topic name matches with or
// without its leading '/'.
absl::StatusOr<LaserTopics> ChooseLaserTopics(const std::vector<bags::BagConnection>& connections,
                                              const std::string& scan_topic,
                                              const std::string& odom_topic);

// "/scan (sensor_msgs/LaserScan), /odom (nav_msgs/Odometry)": every topic, for errors.
std::string DescribeTopics(const std::vector<bags::BagConnection>& connections);

}  // namespace waymark::ros

#endif  // WAYMARK_CLIENT_ROS_BAG_TOPICS_H_
