#ifndef WAYMARK_CLIENT_ROS_BAG_PATH_H_
#define WAYMARK_CLIENT_ROS_BAG_PATH_H_

// Whether a path a command was given is a bag rather than a CARMEN log or an image folder: a
// rosbag2 folder (metadata.yaml, or .db3/.mcap files in it), or a file whose first bytes are a
// ROS 1 bag's (#ROSBAG, #ROSRECORD), an MCAP's (\x89MCAP) or SQLite's (rosbag2 .db3). OpenBag
// decides which reader by the same bytes.

#include <string>

namespace waymark::ros {

bool LooksLikeBag(const std::string& path);

}  // namespace waymark::ros

#endif  // WAYMARK_CLIENT_ROS_BAG_PATH_H_
