#ifndef WAYMARK_CLIENT_BAGS_ROS1_BAG_H_
#define WAYMARK_CLIENT_BAGS_ROS1_BAG_H_

// ROS 1 bag format 2.0 (http://wiki.ros.org/Bags/Format/2.0): a bag header record that points at
// the index (connection records and chunk info records at the end of the file), chunk records
// (none, bz2 or lz4) holding connection and message data records, each chunk followed by index
// data records (time and offset of each of its messages per connection). A bag whose index is
// missing or unreadable (the recorder was killed, the file was cut) is read by walking its records
// from the start, with a warning.

#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "client/bags/bag_reader.h"
#include "client/bags/random_file.h"

namespace waymark::bags {

// The first bytes of a ROS 1 bag of each version.
inline constexpr char kRos1Magic[] = "#ROSBAG V2.0\n";
inline constexpr char kRos1OldMagic[] = "#ROSRECORD V1.2";

absl::StatusOr<std::unique_ptr<BagReader>> OpenRos1Bag(RandomFile file);

}  // namespace waymark::bags

#endif  // WAYMARK_CLIENT_BAGS_ROS1_BAG_H_
