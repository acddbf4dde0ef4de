#ifndef WAYMARK_CLIENT_BAGS_BAG_READER_H_
#define WAYMARK_CLIENT_BAGS_BAG_READER_H_

// One interface over the three recorded-message containers robots write (issue 37):
//   ROS 1 `.bag` (format 2.0; chunks uncompressed, bz2 or lz4),
//   rosbag2 folders or files (sqlite3 `.db3` + metadata.yaml, both schema versions, split bags),
//   MCAP files (chunks uncompressed, lz4 or zstd; the `ros1` and `ros2` profiles).
// A reader hands out raw serialized messages in log-time order with the connection they came on;
// what a message means (LaserScan, Odometry, TF, images) is decoded by client/bags/ros_messages.h
// from the connection's encoding. Readers never CHECK on file contents: a damaged or truncated
// file gives what it holds and a warning; a file that is not a bag, or a format version this
// reader does not read (`#ROSRECORD V1.2`), is a precise error.

#include <cstdint>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"

namespace waymark::bags {

// How a connection's messages are serialized.
enum class MessageEncoding {
  kRos1,  // ROS 1 serialization (little-endian, packed, uint32-length strings and arrays)
  kCdr,   // ROS 2 CDR (XCDR1, encapsulation header first; little or big endian)
  kOther, // anything else (json, protobuf, ...): listed by `bag info`, never decoded
};

// One topic as recorded by one publisher. Several connections may share a topic.
struct BagConnection {
  int id = 0;                 // unique within the bag
  std::string topic;          // "/scan"
  std::string type;           // ROS 1 style "sensor_msgs/LaserScan" (a ROS 2 "sensor_msgs/msg/
                              // LaserScan" is normalized to this form; the original is in raw_type)
  std::string raw_type;       // as written in the file
  MessageEncoding encoding = MessageEncoding::kOther;
  std::string encoding_name;  // as written: "ros1", "cdr", ...
  std::string definition;     // the message definition text when the file carries one
  std::string md5sum;         // ROS 1 md5 when known
  std::string callerid;       // ROS 1 publisher node when known
};

struct BagMessage {
  int connection_id = 0;
  int64_t log_time_ns = 0;    // record time (ROS 1 time / rosbag2 timestamp / MCAP log_time)
  std::string data;           // the serialized message, exactly as stored
};

struct BagTopicSummary {
  std::string topic;
  std::string type;
  int64_t messages = 0;
};

struct BagSummary {
  std::string format;          // "ROS 1 bag v2.0", "rosbag2 sqlite3", "rosbag2 mcap", "MCAP"
  std::string compression;     // "none", "bz2", "lz4", "zstd", or a list
  int64_t start_ns = 0;
  int64_t end_ns = 0;
  int64_t messages = 0;
  std::vector<std::string> files;  // the files read (split bags have several)
  std::vector<BagTopicSummary> topics;  // sorted by topic
};

class BagReader {
 public:
  virtual ~BagReader() = default;

  virtual const std::vector<BagConnection>& connections() const = 0;

  // What the file's index says (for `waymark bag info`), without reading every message when the
  // format has an index; counts may come from reading when it does not.
  virtual absl::StatusOr<BagSummary> Summary() = 0;

  // The next message in log-time order (ties in file order); false at the end. Only messages on
  // the connections in `wanted` when Select was called. A truncated or damaged tail ends the
  // stream early with a warning, not an error.
  virtual absl::StatusOr<bool> Next(BagMessage* message) = 0;

  // Read only these connection ids from now on (empty: all).
  virtual void Select(const std::vector<int>& wanted) = 0;

  // Problems met so far that did not stop reading (truncated chunk, unsorted chunks, ...).
  virtual const std::vector<std::string>& warnings() const = 0;
};

// Opens `path`: a ROS 1 .bag, an .mcap, a rosbag2 folder (with metadata.yaml) or one of its
// .db3/.mcap files. The kind is decided by the file's first bytes, not its name.
absl::StatusOr<std::unique_ptr<BagReader>> OpenBag(const std::string& path);

}  // namespace waymark::bags

#endif  // WAYMARK_CLIENT_BAGS_BAG_READER_H_
