#include "client/ros/ros_messages.h"

#include <cmath>
#include <utility>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"

namespace waymark::ros {
namespace {

// The reader's error, or `value`; the message must have ended.
template <typename T>
absl::StatusOr<T> Finish(WireReader& reader, T value) {
  reader.ExpectEnd();
  if (!reader.ok()) return reader.status();
  return value;
}

Header ReadHeader(WireReader& in) {
  Header header;
  if (in.format() == WireFormat::kRos1) header.seq = in.U32("header.seq");
  header.stamp_ns = in.TimeNs("header.stamp");
  header.frame_id = in.String("header.frame_id");
  return header;
}

Vector3 ReadVector3(WireReader& in, const char* field) {
  Vector3 v;
  v.x = in.F64(field);
  v.y = in.F64(field);
  v.z = in.F64(field);
  return v;
}

Quaternion ReadQuaternion(WireReader& in, const char* field) {
  Quaternion q;
  q.x = in.F64(field);
  q.y = in.F64(field);
  q.z = in.F64(field);
  q.w = in.F64(field);
  return q;
}

std::vector<float> ReadFloat32Sequence(WireReader& in, const char* field) {
  const uint32_t n = in.Count(field, 4);
  std::vector<float> values;
  values.reserve(n);
  for (uint32_t i = 0; i < n && in.ok(); ++i) values.push_back(in.F32(field));
  return values;
}

// float64[N]: no count.
template <size_t N>
std::array<double, N> ReadFloat64Array(WireReader& in, const char* field) {
  std::array<double, N> values{};
  for (double& v : values) v = in.F64(field);
  return values;
}

void SkipFloat64s(WireReader& in, int n, const char* field) {
  for (int i = 0; i < n && in.ok(); ++i) in.F64(field);
}

TransformStampedMsg ReadTransformStamped(WireReader& in) {
  TransformStampedMsg t;
  t.header = ReadHeader(in);
  t.child_frame_id = in.String("transforms[].child_frame_id");
  t.translation = ReadVector3(in, "transforms[].transform.translation");
  t.rotation = ReadQuaternion(in, "transforms[].transform.rotation");
  return t;
}

}  // namespace

RosType RosTypeOf(std::string_view type) {
  std::string name(type);
  // "pkg/msg/Type" (ROS 2) is "pkg/Type".
  if (const size_t msg = name.find("/msg/"); msg != std::string::npos) {
    name.erase(msg, 4);
  }
  if (name == "sensor_msgs/LaserScan") return RosType::kLaserScan;
  if (name == "nav_msgs/Odometry") return RosType::kOdometry;
  if (name == "tf2_msgs/TFMessage" || name == "tf/tfMessage") return RosType::kTfMessage;
  if (name == "sensor_msgs/Image") return RosType::kImage;
  if (name == "sensor_msgs/CompressedImage") return RosType::kCompressedImage;
  if (name == "sensor_msgs/CameraInfo") return RosType::kCameraInfo;
  return RosType::kUnknown;
}

absl::StatusOr<LaserScanMsg> DecodeLaserScan(WireFormat format, std::string_view data,
                                             const MessageOrigin& origin) {
  WireReader in(format, data, origin);
  LaserScanMsg scan;
  scan.header = ReadHeader(in);
  scan.angle_min = in.F32("angle_min");
  scan.angle_max = in.F32("angle_max");
  scan.angle_increment = in.F32("angle_increment");
  scan.time_increment = in.F32("time_increment");
  scan.scan_time = in.F32("scan_time");
  scan.range_min = in.F32("range_min");
  scan.range_max = in.F32("range_max");
  scan.ranges = ReadFloat32Sequence(in, "ranges");
  scan.intensities = ReadFloat32Sequence(in, "intensities");
  return Finish(in, std::move(scan));
}

absl::StatusOr<OdometryMsg> DecodeOdometry(WireFormat format, std::string_view data,
                                           const MessageOrigin& origin) {
  WireReader in(format, data, origin);
  OdometryMsg odometry;
  odometry.header = ReadHeader(in);
  odometry.child_frame_id = in.String("child_frame_id");
  odometry.position = ReadVector3(in, "pose.pose.position");
  odometry.orientation = ReadQuaternion(in, "pose.pose.orientation");
  SkipFloat64s(in, 36, "pose.covariance");
  SkipFloat64s(in, 6, "twist.twist");
  SkipFloat64s(in, 36, "twist.covariance");
  return Finish(in, std::move(odometry));
}

absl::StatusOr<TfMsg> DecodeTf(WireFormat format, std::string_view data,
                               const MessageOrigin& origin) {
  WireReader in(format, data, origin);
  TfMsg tf;
  // A TransformStamped is at least a header (12 bytes), a string (4) and 7 float64.
  const uint32_t n = in.Count("transforms", 12 + 4 + 56);
  tf.transforms.reserve(n);
  for (uint32_t i = 0; i < n && in.ok(); ++i) tf.transforms.push_back(ReadTransformStamped(in));
  return Finish(in, std::move(tf));
}

absl::StatusOr<ImageMsg> DecodeImage(WireFormat format, std::string_view data,
                                     const MessageOrigin& origin) {
  WireReader in(format, data, origin);
  ImageMsg image;
  image.header = ReadHeader(in);
  image.height = in.U32("height");
  image.width = in.U32("width");
  image.encoding = in.String("encoding");
  image.is_bigendian = in.Bool("is_bigendian");
  image.step = in.U32("step");
  const uint32_t size = in.Count("data", 1);
  image.data = std::string(in.Bytes(size, "data"));
  return Finish(in, std::move(image));
}

absl::StatusOr<CompressedImageMsg> DecodeCompressedImage(WireFormat format, std::string_view data,
                                                         const MessageOrigin& origin) {
  WireReader in(format, data, origin);
  CompressedImageMsg image;
  image.header = ReadHeader(in);
  image.format = in.String("format");
  const uint32_t size = in.Count("data", 1);
  image.data = std::string(in.Bytes(size, "data"));
  return Finish(in, std::move(image));
}

absl::StatusOr<CameraInfoMsg> DecodeCameraInfo(WireFormat format, std::string_view data,
                                               const MessageOrigin& origin) {
  WireReader in(format, data, origin);
  CameraInfoMsg info;
  info.header = ReadHeader(in);
  info.height = in.U32("height");
  info.width = in.U32("width");
  info.distortion_model = in.String("distortion_model");
  const uint32_t n = in.Count("D", 8);
  for (uint32_t i = 0; i < n && in.ok(); ++i) info.d.push_back(in.F64("D"));
  info.k = ReadFloat64Array<9>(in, "K");
  info.r = ReadFloat64Array<9>(in, "R");
  info.p = ReadFloat64Array<12>(in, "P");
  in.U32("binning_x");
  in.U32("binning_y");
  in.U32("roi.x_offset");
  in.U32("roi.y_offset");
  in.U32("roi.height");
  in.U32("roi.width");
  in.Bool("roi.do_rectify");
  return Finish(in, std::move(info));
}

double YawOf(const Quaternion& q) {
  return std::atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z));
}

std::string_view FrameName(std::string_view frame_id) {
  while (!frame_id.empty() && frame_id.front() == '/') frame_id.remove_prefix(1);
  return frame_id;
}

}  // namespace waymark::ros
