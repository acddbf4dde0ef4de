#ifndef WAYMARK_SERVER_LASER_SLAM_MAPPING_SEEN_MASK_H_
#define WAYMARK_SERVER_LASER_SLAM_MAPPING_SEEN_MASK_H_

// Where a submap's scans looked: the cells their beams crossed or ended in. A match's score is
// the mean likelihood of all the query's points, so a query whose scanner looked the other way
// (a robot driving back down a corridor, a 180-degree scanner) scores low at the right pose: the
// points that lie where the submap never looked find nothing there, which is no evidence either
// way. OverlapScore scores only the points where the submap looked (docs/laser-slam.md, "Loop
// closure": global_min_overlap).

#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "server/laser_slam/mapping/likelihood_grid.h"
#include "server/laser_slam/mapping/point_cloud.h"
#include "server/laser_slam/types.h"

namespace waymark::laser_slam {

struct SeenMask {
  double resolution = 0.2;
  Eigen::Vector2d origin = Eigen::Vector2d::Zero();  // corner of cell (0, 0)
  int width = 0;
  int height = 0;
  std::vector<std::uint8_t> cells;  // row-major; 1 = looked at

  bool empty() const { return cells.empty(); }
  bool Seen(double x, double y) const;
};

// One scan of a submap: its scanner's place in the submap's frame and its points (scanner frame
// = the node's frame, whose origin the beams are taken to start from).
struct SeenScan {
  Pose2 pose;
  const PointCloud* points = nullptr;
};

// The cells crossed by the beam from each scan's origin to each of its points, and the one
// holding the point, grown by one cell (the poses and the search are good to a cell, not
// better). Empty when the scans span more than `max_cells` cells (corrupt input).
SeenMask BuildSeenMask(const std::vector<SeenScan>& scans, double resolution,
                       std::int64_t max_cells = 4'000'000);

struct OverlapScore {
  double score = 0.0;    // mean likelihood of the points that lie where the submap looked
  double overlap = 0.0;  // their share of all the points, 0..1
};
// `points` (query frame) placed at `pose` in the grid's (and the mask's) frame.
OverlapScore ScoreWhereSeen(const LikelihoodGrid& grid, const SeenMask& seen,
                            const PointCloud& points, const Pose2& pose);

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_MAPPING_SEEN_MASK_H_
