#ifndef WAYMARK_CLIENT_ROS_BAG_IMAGES_H_
#define WAYMARK_CLIENT_ROS_BAG_IMAGES_H_

// A bag's camera topic as an image sequence for `waymark vo run BAG` (issue 37): the frames of one
// sensor_msgs/Image or CompressedImage topic written into a folder (Image as PNG, 16-bit and float
// depth kept; CompressedImage's JPEG or PNG bytes as they are), stamped by their header stamps,
// and the camera's intrinsics from the first sensor_msgs/CameraInfo beside it. The VO runner then
// reads that folder like any other sequence, so it is not written twice.
//
// The image topic is the bag's only Image or CompressedImage topic, or --image-topic; several are
// listed. The CameraInfo topic is the one in the image topic's namespace (/cam/camera_info for
// /cam/image_raw or /cam/image/compressed), else the bag's only one; plumb_bob and
// rational_polynomial give k1 k2 p1 p2 k3, other models (equidistant, ...) are a warning and no
// intrinsics. Frames whose stamp does not increase are skipped and counted; an undecodable frame
// is an error naming the topic.

#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "client/bags/bag_reader.h"
#include "client/datasets/image_sequence.h"

namespace waymark::ros {

struct BagImages {
  cli::ImageSequence sequence;  // layout kTum, no depth, intrinsics from CameraInfo when found
  std::string image_topic;
  std::string camera_info_topic;  // empty: none
  int64_t skipped_stamps = 0;
  std::vector<std::string> warnings;
};

// Reads the frames (at most `max_frames`, 0 = all) into `dir`, created if needed.
absl::StatusOr<BagImages> ExtractBagImages(std::unique_ptr<bags::BagReader> reader,
                                           const std::string& image_topic, int max_frames,
                                           const std::filesystem::path& dir);

}  // namespace waymark::ros

#endif  // WAYMARK_CLIENT_ROS_BAG_IMAGES_H_
