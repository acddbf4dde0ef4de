#ifndef WAYMARK_CLIENT_ROS_ROS_IMAGES_H_
#define WAYMARK_CLIENT_ROS_ROS_IMAGES_H_

// ROS images into OpenCV matrices (the only OpenCV code of client/ros, in its own library
// waymark_ros_images so the decoders stay free of it).
//
// sensor_msgs/Image: mono8 (CV_8UC1), rgb8 and bgr8 (CV_8UC3, as BGR), rgba8 and bgra8 (CV_8UC3,
// alpha dropped), mono16 and 16UC1 (CV_16UC1), 32FC1 (CV_32FC1); big-endian data is swapped.
// Rows are copied out of `step`-byte rows. Any other encoding (bayer_*, yuv422, 8UC3, ...) is
// INVALID_ARGUMENT naming the encoding and the topic.
// sensor_msgs/CompressedImage: JPEG or PNG data decoded with cv::imdecode (colour as BGR, 16-bit
// PNG kept 16-bit); compressedDepth (a 12-byte header before a PNG) and anything imdecode cannot
// read are precise errors.

#include <string>

#include <opencv2/core.hpp>

#include "absl/status/statusor.h"
#include "client/ros/ros_messages.h"

namespace waymark::ros {

absl::StatusOr<cv::Mat> ImageToMat(const ImageMsg& image, const MessageOrigin& origin);
absl::StatusOr<cv::Mat> CompressedImageToMat(const CompressedImageMsg& image,
                                             const MessageOrigin& origin);

}  // namespace waymark::ros

#endif  // WAYMARK_CLIENT_ROS_ROS_IMAGES_H_
