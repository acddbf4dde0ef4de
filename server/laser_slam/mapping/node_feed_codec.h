#ifndef WAYMARK_SERVER_LASER_SLAM_MAPPING_NODE_FEED_CODEC_H_
#define WAYMARK_SERVER_LASER_SLAM_MAPPING_NODE_FEED_CODEC_H_

// A trajectory's nodes as a server publishes them for the server that owns their shared map
// (issue 38, a fleet on one database; the service's map_tie_worker.h): in two parts, because a
// node's points never change once it is made and its pose changes with every loop closure.
// - The poses: every node's scan, stamp, pose in the session's frame and chain sigma, and the
//   session's loop closures; written again at each publish (about 60 bytes a node).
// - A node's points (robot frame), written once, when the node is new.
// The reader joins them again into the NodeViews the tie and the follow read. Bytes come from a
// database another server wrote: everything is checked, and bad bytes give DATA_LOSS.

#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "server/laser_slam/mapping/mapping_backend.h"
#include "server/laser_slam/mapping/point_cloud.h"
#include "server/laser_slam/mapping/pose_graph.h"

namespace waymark::laser_slam {

// The nodes without their points (NodeView.points null), in scan order, and the loops by node
// index.
struct FeedPoses {
  std::vector<NodeView> nodes;
  std::vector<GraphConstraint> loops;
};

std::string EncodeFeedPoses(const std::vector<NodeView>& nodes,
                            const std::vector<GraphConstraint>& loops);
// DATA_LOSS unless: the feed's magic and version, scans rising, stamps and sigmas finite, poses
// on the map, loops between its nodes.
absl::StatusOr<FeedPoses> DecodeFeedPoses(absl::string_view bytes);

std::string EncodeFeedPoints(const PointCloud& points);
absl::StatusOr<PointCloud> DecodeFeedPoints(absl::string_view bytes);

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_MAPPING_NODE_FEED_CODEC_H_
