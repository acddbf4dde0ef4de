#ifndef WAYMARK_CLIENT_DATASETS_STAMPED_POSE3_H_
#define WAYMARK_CLIENT_DATASETS_STAMPED_POSE3_H_

#include <Eigen/Core>

namespace waymark::cli {

// A full 3-D pose (camera or body to world) with its time stamp in seconds.
struct StampedPose3 {
  double stamp = 0;
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
};

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_DATASETS_STAMPED_POSE3_H_
