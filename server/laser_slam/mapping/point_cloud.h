#ifndef WAYMARK_SERVER_LASER_SLAM_MAPPING_POINT_CLOUD_H_
#define WAYMARK_SERVER_LASER_SLAM_MAPPING_POINT_CLOUD_H_

// The scan points the back end keeps: laser returns as 2-D points in a node's (robot) frame,
// thinned to one per grid cell so that a node costs a few kilobytes.

#include <vector>

#include <Eigen/Core>

#include "server/laser_slam/types.h"

namespace waymark::laser_slam {

using PointCloud = std::vector<Eigen::Vector2f>;

// The returns of `scan` within [min_range, max_range], in the robot frame (laser at `laser_pose`).
PointCloud ScanToPoints(const LaserScan& scan, const Pose2& laser_pose, double min_range,
                        double max_range);

// One point per `cell` x `cell` square (the first one seen), order kept.
PointCloud ThinPoints(const PointCloud& points, double cell);

// `points` moved by `pose` (points given in the frame whose location is `pose`).
PointCloud TransformPoints(const PointCloud& points, const Pose2& pose);
void AppendTransformed(const PointCloud& points, const Pose2& pose, PointCloud* out);

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_MAPPING_POINT_CLOUD_H_
