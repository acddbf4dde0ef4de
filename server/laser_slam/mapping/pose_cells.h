#ifndef WAYMARK_SERVER_LASER_SLAM_MAPPING_POSE_CELLS_H_
#define WAYMARK_SERVER_LASER_SLAM_MAPPING_POSE_CELLS_H_

// The poses of several trajectories hashed in square cells of a radius, so that the nearest pose
// of another trajectory within that radius is among the 3 x 3 cells around a point: a map
// revisited for hours holds tens of thousands of nodes, and each of as many samples looks for one
// (the map's graph anchoring its samples, map_graph.h; the map's path relating them,
// trajectory_tie.h's MapPath).

#include <cstdint>
#include <unordered_map>
#include <utility>
#include <vector>

#include "server/laser_slam/types.h"

namespace waymark::laser_slam {

class PoseCells {
 public:
  // `owner[k]`: the trajectory pose k belongs to. Both are held by reference: they must outlive
  // this. `radius` > 0.
  PoseCells(const std::vector<Pose2>& poses, const std::vector<int>& owner, double radius);

  // The nearest pose of a trajectory other than `self` to `at` within the radius (-1: none).
  int NearestOther(int self, const Pose2& at) const;

 private:
  std::pair<std::int64_t, std::int64_t> Cell(double x, double y) const;
  static std::uint64_t Pack(std::int64_t cx, std::int64_t cy);

  const std::vector<Pose2>& poses_;
  const std::vector<int>& owner_;
  const double radius_;
  std::unordered_map<std::uint64_t, std::vector<int>> cells_;
};

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_MAPPING_POSE_CELLS_H_
