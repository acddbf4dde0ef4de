// The ROS message decoders (client/ros/ros_messages.h) on bytes written by ROS's own serializers:
// ROS 1 by Debian's genpy message classes (write_ros1_messages.py), CDR by Foxglove's ROS 2
// serializer in node (write_cdr_messages.js). Every truncation of every message is a precise
// error naming the topic and a field, never a crash; images convert to OpenCV matrices.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <string>

#include "client/ros/ros_images.h"
#include "client/ros/ros_messages.h"
#include "tests/ros/ros_test_util.h"

namespace waymark::ros {
namespace {

using ::testing::HasSubstr;

// The messages both writers wrote, once per test program.
class RosMessagesTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() { dir_ = new testing::WrittenMessages(); }
  static void TearDownTestSuite() { delete dir_; }

  static std::string Bytes(const std::string& name) { return dir_->Read(name); }

  static testing::WrittenMessages* dir_;
};
testing::WrittenMessages* RosMessagesTest::dir_ = nullptr;

const MessageOrigin kScanOrigin{"/scan", "sensor_msgs/LaserScan"};

void ExpectScan(const LaserScanMsg& scan, bool ros1) {
  EXPECT_EQ(scan.header.seq, ros1 ? 7u : 0u);
  EXPECT_EQ(scan.header.stamp_ns, 1518520222271470000);
  EXPECT_EQ(FrameName(scan.header.frame_id), "base_laser");
  EXPECT_FLOAT_EQ(scan.angle_min, -2.356194496154785f);
  EXPECT_FLOAT_EQ(scan.angle_max, 2.356194496154785f);
  EXPECT_FLOAT_EQ(scan.angle_increment, 0.006135923322290182f);
  EXPECT_FLOAT_EQ(scan.scan_time, 0.1f);
  EXPECT_FLOAT_EQ(scan.range_min, 0.02f);
  EXPECT_FLOAT_EQ(scan.range_max, 5.6f);
  ASSERT_EQ(scan.ranges.size(), 5u);
  EXPECT_FLOAT_EQ(scan.ranges[1], 2.5f);
  EXPECT_TRUE(std::isinf(scan.ranges[2]));
  EXPECT_FLOAT_EQ(scan.ranges[4], 5.5f);
  ASSERT_EQ(scan.intensities.size(), 2u);
  EXPECT_FLOAT_EQ(scan.intensities[1], 200.0f);
}

TEST_F(RosMessagesTest, LaserScanFromGenpyAndFromFoxgloveCdrBothEndians) {
  auto ros1 = DecodeLaserScan(WireFormat::kRos1, Bytes("laserscan.ros1"), kScanOrigin);
  ASSERT_TRUE(ros1.ok()) << ros1.status();
  EXPECT_EQ(ros1->header.frame_id, "/base_laser");  // kept as written; FrameName drops the '/'
  ExpectScan(*ros1, true);
  for (const char* name : {"laserscan.cdr", "laserscan_be.cdr"}) {
    auto cdr = DecodeLaserScan(WireFormat::kCdr, Bytes(name), kScanOrigin);
    ASSERT_TRUE(cdr.ok()) << name << ": " << cdr.status();
    ExpectScan(*cdr, false);
  }
}

TEST_F(RosMessagesTest, OdometryPoseAndEmptyChildFrame) {
  for (const auto& [name, format] : {std::pair{"odometry.ros1", WireFormat::kRos1},
                                     std::pair{"odometry.cdr", WireFormat::kCdr}}) {
    auto odometry = DecodeOdometry(format, Bytes(name), {"/odom", "nav_msgs/Odometry"});
    ASSERT_TRUE(odometry.ok()) << name << ": " << odometry.status();
    EXPECT_EQ(odometry->header.stamp_ns, 60200000000);
    EXPECT_EQ(odometry->header.frame_id, "odom");
    EXPECT_EQ(odometry->child_frame_id, "");
    EXPECT_DOUBLE_EQ(odometry->position.x, 1.5);
    EXPECT_DOUBLE_EQ(odometry->position.y, -2.25);
    EXPECT_NEAR(YawOf(odometry->orientation), M_PI / 4, 1e-12);
  }
}

TEST_F(RosMessagesTest, TfMessageTransforms) {
  for (const auto& [name, format] :
       {std::pair{"tf.ros1", WireFormat::kRos1}, std::pair{"tf.cdr", WireFormat::kCdr}}) {
    auto tf = DecodeTf(format, Bytes(name), {"/tf", "tf2_msgs/TFMessage"});
    ASSERT_TRUE(tf.ok()) << name << ": " << tf.status();
    ASSERT_EQ(tf->transforms.size(), 2u);
    EXPECT_EQ(tf->transforms[0].header.frame_id, "odom");
    EXPECT_EQ(tf->transforms[0].child_frame_id, "base_link");
    EXPECT_DOUBLE_EQ(tf->transforms[0].translation.x, 0.5);
    EXPECT_EQ(tf->transforms[1].child_frame_id, "laser");
    EXPECT_DOUBLE_EQ(tf->transforms[1].translation.x, 0.2);
    EXPECT_EQ(tf->transforms[1].header.stamp_ns, 100000000005);
  }
  EXPECT_EQ(RosTypeOf("tf/tfMessage"), RosType::kTfMessage);
  EXPECT_EQ(RosTypeOf("tf2_msgs/msg/TFMessage"), RosType::kTfMessage);
  EXPECT_EQ(RosTypeOf("sensor_msgs/msg/LaserScan"), RosType::kLaserScan);
  EXPECT_EQ(RosTypeOf("sensor_msgs/PointCloud2"), RosType::kUnknown);
}

TEST_F(RosMessagesTest, CameraInfoIntrinsics) {
  for (const auto& [name, format] : {std::pair{"camerainfo.ros1", WireFormat::kRos1},
                                     std::pair{"camerainfo.cdr", WireFormat::kCdr}}) {
    auto info = DecodeCameraInfo(format, Bytes(name), {"/camera_info", "sensor_msgs/CameraInfo"});
    ASSERT_TRUE(info.ok()) << name << ": " << info.status();
    EXPECT_EQ(info->width, 1280u);
    EXPECT_EQ(info->height, 960u);
    EXPECT_EQ(info->distortion_model, "plumb_bob");
    ASSERT_EQ(info->d.size(), 5u);
    EXPECT_DOUBLE_EQ(info->d[1], -0.2);
    EXPECT_DOUBLE_EQ(info->k[0], 1000.0);
    EXPECT_DOUBLE_EQ(info->k[2], 640.0);
    EXPECT_DOUBLE_EQ(info->k[4], 1001.0);
    EXPECT_DOUBLE_EQ(info->k[5], 480.0);
    EXPECT_DOUBLE_EQ(info->p[10], 1.0);
  }
}

TEST_F(RosMessagesTest, ImagesToMatsAndUnknownEncodingsNamed) {
  const MessageOrigin origin{"/camera/image", "sensor_msgs/Image"};
  for (const auto& [name, format] : {std::pair{"image_rgb8.ros1", WireFormat::kRos1},
                                     std::pair{"image_rgb8.cdr", WireFormat::kCdr}}) {
    auto image = DecodeImage(format, Bytes(name), origin);
    ASSERT_TRUE(image.ok()) << name << ": " << image.status();
    auto mat = ImageToMat(*image, origin);
    ASSERT_TRUE(mat.ok()) << mat.status();
    ASSERT_EQ(mat->type(), CV_8UC3);
    ASSERT_EQ(mat->cols, 3);
    ASSERT_EQ(mat->rows, 2);
    // rgb8 bytes 0,1,2 are pixel (0,0): BGR holds them reversed.
    EXPECT_EQ(mat->at<cv::Vec3b>(0, 0), cv::Vec3b(2, 1, 0));
    EXPECT_EQ(mat->at<cv::Vec3b>(1, 2), cv::Vec3b(17, 16, 15));
  }
  auto yuv = DecodeImage(WireFormat::kRos1, Bytes("image_yuv422.ros1"), origin);
  ASSERT_TRUE(yuv.ok()) << yuv.status();
  auto refused = ImageToMat(*yuv, origin);
  ASSERT_FALSE(refused.ok());
  EXPECT_THAT(refused.status().message(), HasSubstr("'yuv422'"));
  EXPECT_THAT(refused.status().message(), HasSubstr("/camera/image"));

  // 16UC1 big-endian and 32FC1, built here: the values survive.
  ImageMsg depth;
  depth.width = 2;
  depth.height = 1;
  depth.encoding = "16UC1";
  depth.is_bigendian = true;
  depth.step = 4;
  depth.data = std::string("\x01\x02\x00\x05", 4);
  auto depth_mat = ImageToMat(depth, origin);
  ASSERT_TRUE(depth_mat.ok()) << depth_mat.status();
  EXPECT_EQ(depth_mat->at<uint16_t>(0, 0), 0x0102);
  EXPECT_EQ(depth_mat->at<uint16_t>(0, 1), 0x0005);
  depth.step = 3;  // shorter than a row
  EXPECT_THAT(ImageToMat(depth, origin).status().message(), HasSubstr("step 3"));
}

TEST_F(RosMessagesTest, CompressedImagesDecodeWithOpenCv) {
  const MessageOrigin origin{"/camera/image/compressed", "sensor_msgs/CompressedImage"};
  auto compressed = DecodeCompressedImage(WireFormat::kRos1, Bytes("compressed.ros1"), origin);
  ASSERT_TRUE(compressed.ok()) << compressed.status();
  EXPECT_EQ(compressed->format, "png");
  // Its data is not a real PNG: a precise error.
  auto bad = CompressedImageToMat(*compressed, origin);
  ASSERT_FALSE(bad.ok());
  EXPECT_THAT(bad.status().message(), HasSubstr("cannot decode"));
  EXPECT_THAT(bad.status().message(), HasSubstr("/camera/image/compressed"));
  // A real PNG and a real JPEG.
  cv::Mat picture(4, 6, CV_8UC3, cv::Scalar(10, 20, 30));
  for (const char* ext : {".png", ".jpg"}) {
    std::vector<uchar> buffer;
    ASSERT_TRUE(cv::imencode(ext, picture, buffer));
    CompressedImageMsg message;
    message.format = ext + 1;
    message.data.assign(buffer.begin(), buffer.end());
    auto mat = CompressedImageToMat(message, origin);
    ASSERT_TRUE(mat.ok()) << ext << ": " << mat.status();
    EXPECT_EQ(mat->cols, 6);
    EXPECT_EQ(mat->rows, 4);
    EXPECT_NEAR(mat->at<cv::Vec3b>(2, 3)[2], 30, 3);
  }
  CompressedImageMsg depth;
  depth.format = "16UC1; compressedDepth png";
  depth.data = "x";
  EXPECT_THAT(CompressedImageToMat(depth, origin).status().message(),
              HasSubstr("compressedDepth"));
}

// Every prefix of every message, in both formats, is an error that names the topic and a field:
// never a crash, never a message decoded from too few bytes.
TEST_F(RosMessagesTest, EveryTruncationIsAPreciseError) {
  struct Case {
    std::string file;
    WireFormat format;
    std::function<absl::Status(WireFormat, std::string_view, const MessageOrigin&)> decode;
  };
  auto status_of = [](auto decoder) {
    return [decoder](WireFormat f, std::string_view d, const MessageOrigin& o) {
      return decoder(f, d, o).status();
    };
  };
  std::vector<Case> cases;
  for (WireFormat format : {WireFormat::kRos1, WireFormat::kCdr}) {
    const std::string ext = format == WireFormat::kRos1 ? ".ros1" : ".cdr";
    cases.push_back({"laserscan" + ext, format, status_of(DecodeLaserScan)});
    cases.push_back({"odometry" + ext, format, status_of(DecodeOdometry)});
    cases.push_back({"tf" + ext, format, status_of(DecodeTf)});
    cases.push_back({"image_rgb8" + ext, format, status_of(DecodeImage)});
    cases.push_back({"camerainfo" + ext, format, status_of(DecodeCameraInfo)});
  }
  const MessageOrigin origin{"/some/topic", "some/Type"};
  for (const Case& c : cases) {
    const std::string bytes = Bytes(c.file);
    ASSERT_TRUE(c.decode(c.format, bytes, origin).ok()) << c.file;
    // CDR may end in up to 3 bytes of padding: cutting those off still decodes.
    const size_t shortest_whole = c.format == WireFormat::kCdr ? bytes.size() - 3 : bytes.size();
    for (size_t n = 0; n < bytes.size(); ++n) {
      const absl::Status status = c.decode(c.format, std::string_view(bytes).substr(0, n), origin);
      if (n >= shortest_whole && status.ok()) continue;
      ASSERT_FALSE(status.ok()) << c.file << " cut to " << n << " of " << bytes.size();
      EXPECT_EQ(status.code(), absl::StatusCode::kInvalidArgument);
      EXPECT_THAT(status.message(), HasSubstr("topic /some/topic (some/Type"));
      EXPECT_THAT(status.message(), HasSubstr("field '"));
    }
    // A byte too many is another type or version (ROS 1 has no padding).
    if (c.format == WireFormat::kRos1) {
      EXPECT_THAT(c.decode(c.format, bytes + "x", origin).message(), HasSubstr("left after"));
    }
  }
}

TEST_F(RosMessagesTest, CorruptCountsAndHeadersAreRefusedWithoutAllocating) {
  // A LaserScan whose ranges count says 2^31: refused by the bytes left, not allocated.
  std::string bytes = Bytes("laserscan.ros1");
  const size_t count_at = 4 + 8 + 4 + 11 + 7 * 4;  // seq, stamp, frame_id (11 chars), 7 floats
  bytes[count_at + 3] = '\x80';
  auto scan = DecodeLaserScan(WireFormat::kRos1, bytes, kScanOrigin);
  ASSERT_FALSE(scan.ok());
  EXPECT_THAT(scan.status().message(), HasSubstr("field 'ranges'"));
  EXPECT_THAT(scan.status().message(), HasSubstr("element(s)"));

  // A parameter-list CDR encapsulation is named.
  std::string cdr = Bytes("laserscan.cdr");
  cdr[1] = '\x03';
  EXPECT_THAT(DecodeLaserScan(WireFormat::kCdr, cdr, kScanOrigin).status().message(),
              HasSubstr("encapsulation kind 0x03"));
  // A CDR string without its NUL.
  cdr = Bytes("laserscan.cdr");
  cdr[4 + 8 + 4 + 10] = 'x';  // the NUL after "base_laser"
  EXPECT_THAT(DecodeLaserScan(WireFormat::kCdr, cdr, kScanOrigin).status().message(),
              HasSubstr("NUL"));
}

}  // namespace
}  // namespace waymark::ros
