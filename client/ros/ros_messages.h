#ifndef WAYMARK_CLIENT_ROS_ROS_MESSAGES_H_
#define WAYMARK_CLIENT_ROS_ROS_MESSAGES_H_

// The ROS messages a replay reads out of a bag, decoded from ROS 1 serialization or CDR
// (ros_wire.h) into plain structs: sensor_msgs/LaserScan, nav_msgs/Odometry, tf2_msgs/TFMessage
// (and the old tf/tfMessage, the same layout), sensor_msgs/Image, sensor_msgs/CompressedImage and
// sensor_msgs/CameraInfo. Every field of the message is read (so a message of another type or
// version is caught by its length), the ones a replay needs are kept. A short or malformed message
// is INVALID_ARGUMENT naming the topic, the type and the field; nothing here crashes on bytes.
// Field layouts: ros/common_msgs (ROS 1) and ros2/common_interfaces (ROS 2); they differ only in
// the Header (ROS 2 has no seq) and the time (int32 sec in ROS 2).

#include <array>
#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "absl/status/statusor.h"
#include "client/ros/ros_wire.h"

namespace waymark::ros {

// The message types decoded here, from a ROS 1 style name ("sensor_msgs/LaserScan"; the ROS 2
// "sensor_msgs/msg/LaserScan" is taken too).
enum class RosType {
  kUnknown,
  kLaserScan,
  kOdometry,
  kTfMessage,  // tf2_msgs/TFMessage or tf/tfMessage
  kImage,
  kCompressedImage,
  kCameraInfo,
};
RosType RosTypeOf(std::string_view type);

struct Header {
  uint32_t seq = 0;  // ROS 1 only
  int64_t stamp_ns = 0;
  std::string frame_id;
};

struct Vector3 {
  double x = 0, y = 0, z = 0;
};
struct Quaternion {
  double x = 0, y = 0, z = 0, w = 1;
};

struct LaserScanMsg {
  Header header;
  float angle_min = 0;
  float angle_max = 0;
  float angle_increment = 0;
  float time_increment = 0;
  float scan_time = 0;
  float range_min = 0;
  float range_max = 0;
  std::vector<float> ranges;
  std::vector<float> intensities;
};

// The pose part (the twist and both covariances are read and dropped).
struct OdometryMsg {
  Header header;              // frame_id: the odometry frame ("odom")
  std::string child_frame_id; // the robot's frame ("base_link"); empty in some (Stage) bags
  Vector3 position;
  Quaternion orientation;
};

struct TransformStampedMsg {
  Header header;               // frame_id: the parent frame
  std::string child_frame_id;
  Vector3 translation;
  Quaternion rotation;
};

struct TfMsg {
  std::vector<TransformStampedMsg> transforms;
};

struct ImageMsg {
  Header header;
  uint32_t height = 0;
  uint32_t width = 0;
  std::string encoding;  // "mono8", "rgb8", "16UC1", ...
  bool is_bigendian = false;
  uint32_t step = 0;     // bytes per row
  std::string data;
};

struct CompressedImageMsg {
  Header header;
  std::string format;  // "jpeg", "png", "rgb8; jpeg compressed bgr8", ...
  std::string data;
};

struct CameraInfoMsg {
  Header header;
  uint32_t height = 0;
  uint32_t width = 0;
  std::string distortion_model;  // "plumb_bob", "rational_polynomial", "equidistant", ...
  std::vector<double> d;
  std::array<double, 9> k{};   // row-major 3x3: fx 0 cx / 0 fy cy / 0 0 1
  std::array<double, 9> r{};
  std::array<double, 12> p{};
};

// Each decodes one whole message; `origin` names it in errors.
absl::StatusOr<LaserScanMsg> DecodeLaserScan(WireFormat format, std::string_view data,
                                             const MessageOrigin& origin);
absl::StatusOr<OdometryMsg> DecodeOdometry(WireFormat format, std::string_view data,
                                           const MessageOrigin& origin);
absl::StatusOr<TfMsg> DecodeTf(WireFormat format, std::string_view data,
                               const MessageOrigin& origin);
absl::StatusOr<ImageMsg> DecodeImage(WireFormat format, std::string_view data,
                                     const MessageOrigin& origin);
absl::StatusOr<CompressedImageMsg> DecodeCompressedImage(WireFormat format, std::string_view data,
                                                         const MessageOrigin& origin);
absl::StatusOr<CameraInfoMsg> DecodeCameraInfo(WireFormat format, std::string_view data,
                                               const MessageOrigin& origin);

// The yaw (rotation about z) of a quaternion.
double YawOf(const Quaternion& q);

// A frame id without the leading '/' ROS 1 allowed ("/base_link" and "base_link" are one frame).
std::string_view FrameName(std::string_view frame_id);

}  // namespace waymark::ros

#endif  // WAYMARK_CLIENT_ROS_ROS_MESSAGES_H_
