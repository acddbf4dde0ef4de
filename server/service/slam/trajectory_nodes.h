#ifndef WAYMARK_SERVER_SERVICE_SLAM_TRAJECTORY_NODES_H_
#define WAYMARK_SERVER_SERVICE_SLAM_TRAJECTORY_NODES_H_

#include <cstdint>
#include <vector>

#include "server/laser_slam/mapping/mapping_backend.h"
#include "server/laser_slam/mapping/pose_graph.h"

namespace waymark::service {

// A laser session's nodes as its graph now places them (its own frame), and the loop closures
// of that graph (enabled, by node index): what shared maps read of a session
// (SessionQueries::TrajectoryNodesOf).
struct TrajectoryNodes {
  std::vector<laser_slam::NodeView> nodes;
  bool resident = false;  // false: read from its checkpoint or its feed (trajectory_feed.h)
  int64_t scans_processed = 0;  // the session's when its nodes were read (at most: read first)
  std::vector<laser_slam::GraphConstraint> loops;
};

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_SLAM_TRAJECTORY_NODES_H_
