// Fuzz targets of recorded robot messages (issue 37): the bag readers of client/bags and the ROS
// message decoders of client/ros, which read files a user hands to `waymark bag info`, `slam
// replay BAG` and `vo run BAG`.
//
// bag_files: the input is a whole file, written to a private temporary folder as input.bag and
// opened with OpenBag, which picks the reader from its first bytes: a ROS 1 bag, an MCAP file, a
// rosbag2 .db3 (SQLite) file, or rosbag2's metadata.yaml. Then Summary, and Next until the end
// (at most kMaxMessages, so that a run stays bounded), each message decoded as its connection's
// type says when it is one of the decoded types; after kSelectAfter messages Select keeps every
// other connection, and every message after it must be on one of those (the oracle beyond "no
// crash").
//
// ros_messages: [type][encoding][message bytes]: the first byte picks LaserScan, Odometry, TF,
// Image, CompressedImage or CameraInfo (modulo 6), the second ROS 1 (even) or CDR (odd); a raw
// Image that decodes is also made into a cv::Mat (ImageToMat checks its step and size against its
// data). Compressed images are not handed to OpenCV here: image_decoding fuzzes cv::imdecode.
//
// The seeds of both are files in corpus/bag_files/ and corpus/ros_messages/, written by ROS's and
// Foxglove's own writers (write_bag_seeds.py; their READMEs list them), not made here.

#include <fcntl.h>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <set>
#include <string>
#include <string_view>
#include <vector>

#include "client/bags/bag_reader.h"
#include "client/ros/ros_images.h"
#include "client/ros/ros_messages.h"
#include "tests/fuzz/fuzz_targets.h"
#include "tests/fuzz/service_calls.h"

namespace waymark::fuzz {
namespace {

namespace fs = std::filesystem;

constexpr int kMaxMessages = 5000;
constexpr int kSelectAfter = 16;

// Decodes `data` as `type` in `format`; a raw image that decodes is converted too.
void Decode(ros::RosType type, ros::WireFormat format, std::string_view data,
            const ros::MessageOrigin& origin) {
  switch (type) {
    case ros::RosType::kLaserScan: (void)ros::DecodeLaserScan(format, data, origin); break;
    case ros::RosType::kOdometry: {
      absl::StatusOr<ros::OdometryMsg> odometry = ros::DecodeOdometry(format, data, origin);
      if (odometry.ok()) (void)ros::YawOf(odometry->orientation);
      break;
    }
    case ros::RosType::kTfMessage: {
      absl::StatusOr<ros::TfMsg> tf = ros::DecodeTf(format, data, origin);
      if (!tf.ok()) break;
      for (const ros::TransformStampedMsg& t : tf->transforms) {
        (void)ros::FrameName(t.header.frame_id);
        (void)ros::FrameName(t.child_frame_id);
      }
      break;
    }
    case ros::RosType::kImage: {
      absl::StatusOr<ros::ImageMsg> image = ros::DecodeImage(format, data, origin);
      if (image.ok()) (void)ros::ImageToMat(*image, origin);
      break;
    }
    case ros::RosType::kCompressedImage:
      (void)ros::DecodeCompressedImage(format, data, origin);
      break;
    case ros::RosType::kCameraInfo: (void)ros::DecodeCameraInfo(format, data, origin); break;
    case ros::RosType::kUnknown: break;
  }
}

// --- ros_messages -----------------------------------------------------------------------------
void RosMessages(const uint8_t* data, size_t size) {
  static const ros::RosType kTypes[] = {ros::RosType::kLaserScan, ros::RosType::kOdometry,
                                        ros::RosType::kTfMessage, ros::RosType::kImage,
                                        ros::RosType::kCompressedImage, ros::RosType::kCameraInfo};
  static const char* const kNames[] = {"sensor_msgs/LaserScan", "nav_msgs/Odometry",
                                       "tf2_msgs/TFMessage", "sensor_msgs/Image",
                                       "sensor_msgs/CompressedImage", "sensor_msgs/CameraInfo"};
  if (size < 2) return;
  const size_t which = data[0] % std::size(kTypes);
  const ros::WireFormat format = (data[1] & 1) ? ros::WireFormat::kCdr : ros::WireFormat::kRos1;
  Decode(kTypes[which], format,
         std::string_view(reinterpret_cast<const char*>(data) + 2, size - 2),
         ros::MessageOrigin{"/fuzz", kNames[which]});
}

// --- bag_files --------------------------------------------------------------------------------
// A folder of this process's own under the temp dir, holding the input as input.bag; removed at
// exit. Whatever a reader left next to the input (SQLite's -wal/-shm files) is removed after each
// run, so that every input meets the same folder.
class InputFolder {
 public:
  InputFolder() {
    std::string pattern = (fs::temp_directory_path() / "waymark-fuzz-bag-XXXXXX").string();
    Require(mkdtemp(pattern.data()) != nullptr, "creating a temporary folder");
    folder_ = pattern;
    path_ = (fs::path(folder_) / "input.bag").string();
  }
  ~InputFolder() {
    std::error_code error;
    fs::remove_all(folder_, error);
  }

  // Writes the input over the last one (pwrite and ftruncate: no fresh file for each input).
  const std::string& Write(const uint8_t* data, size_t size) {
    const int fd = open(path_.c_str(), O_WRONLY | O_CREAT | O_CLOEXEC, 0600);
    Require(fd >= 0, "opening the input file");
    size_t done = 0;
    while (done < size) {
      const ssize_t n = pwrite(fd, data + done, size - done, static_cast<off_t>(done));
      Require(n > 0, "writing the input file");
      done += static_cast<size_t>(n);
    }
    Require(ftruncate(fd, static_cast<off_t>(size)) == 0, "truncating the input file");
    close(fd);
    return path_;
  }

  void RemoveOthers() {
    std::error_code error;
    for (const fs::directory_entry& entry : fs::directory_iterator(folder_, error)) {
      if (entry.path() != path_) fs::remove_all(entry.path(), error);
    }
  }

 private:
  std::string folder_;
  std::string path_;
};

void ReadBag(bags::BagReader& bag) {
  (void)bag.Summary();
  std::vector<bags::BagConnection> connections = bag.connections();
  std::set<int> wanted;
  bags::BagMessage message;
  for (int n = 0; n < kMaxMessages; ++n) {
    if (n == kSelectAfter && connections.size() > 1) {
      for (size_t i = 0; i < connections.size(); i += 2) wanted.insert(connections[i].id);
      bag.Select(std::vector<int>(wanted.begin(), wanted.end()));
    }
    absl::StatusOr<bool> more = bag.Next(&message);
    if (!more.ok() || !*more) break;
    Require(wanted.empty() || wanted.count(message.connection_id) > 0,
            "a message on a connection Select left out");
    for (const bags::BagConnection& connection : connections) {
      if (connection.id != message.connection_id) continue;
      if (connection.encoding == bags::MessageEncoding::kOther) break;
      Decode(ros::RosTypeOf(connection.type),
             connection.encoding == bags::MessageEncoding::kCdr ? ros::WireFormat::kCdr
                                                                 : ros::WireFormat::kRos1,
             message.data, ros::MessageOrigin{connection.topic, connection.type});
      break;
    }
  }
  (void)bag.warnings();
}

void BagFiles(const uint8_t* data, size_t size) {
  static InputFolder folder;
  const std::string& path = folder.Write(data, size);
  {
    absl::StatusOr<std::unique_ptr<bags::BagReader>> bag = bags::OpenBag(path);
    if (bag.ok()) ReadBag(**bag);
  }  // the reader and its files are closed before the folder is cleaned
  folder.RemoveOthers();
}

std::vector<std::string> NoSeeds() { return {}; }

}  // namespace

FuzzTarget BagFilesTarget() { return {"bag_files", BagFiles, NoSeeds}; }
FuzzTarget RosMessagesTarget() { return {"ros_messages", RosMessages, NoSeeds}; }

}  // namespace waymark::fuzz
