#ifndef WAYMARK_SERVER_LASER_SLAM_MOTION_H_
#define WAYMARK_SERVER_LASER_SLAM_MOTION_H_

// Robot motion shared by the filter and the planner: the odometry error model of one increment
// and the unicycle arc a constant control produces.

#include <Eigen/Core>

#include "server/laser_slam/options.h"
#include "server/laser_slam/types.h"

namespace waymark::laser_slam {

// Error covariance of one odometry increment `u` (robot frame at its end), OdometryNoise model.
Eigen::Matrix3d IncrementNoise(const Pose2& u, const OdometryNoise& noise);

// The pose increment of a unicycle holding (linear, angular) for `seconds`: an exact arc.
Pose2 UnicycleArc(double linear, double angular, double seconds);

// The robot covariance after moving by `u`: F C F^T + Q(u), as SegmentEkf::Predict computes it.
Eigen::Matrix3d PredictRobotCovariance(const Eigen::Matrix3d& covariance, const Pose2& u,
                                       const OdometryNoise& noise);

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_MOTION_H_
