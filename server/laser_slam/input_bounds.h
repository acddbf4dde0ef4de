#ifndef WAYMARK_SERVER_LASER_SLAM_INPUT_BOUNDS_H_
#define WAYMARK_SERVER_LASER_SLAM_INPUT_BOUNDS_H_

// What the laser engine accepts as physically meaningful. Beyond these a number is a corrupt
// message, not a measurement: odometry of x = 1e300 used to be accepted (only NaN and inf were
// checked) and filled the session's pose and covariance with inf and NaN.

#include "server/common/input_bounds.h"  // kMaxAbsStampS, PlausibleStamp

namespace waymark::laser_slam {

// Odometry coordinates: 1000 km from the base's odometry origin.
inline constexpr double kMaxAbsOdometryM = 1e6;
// Odometry heading, unwrapped (a base may count turns): about 1600 turns.
inline constexpr double kMaxAbsOdometryRad = 1e4;
// Odometry travel between two processed scans. A larger jump is a reset of the base's odometry
// (a reboot, a wrapped counter), not a motion: the scan is processed with no motion and the
// answer says so (ScanUpdate::odometry_reset), instead of a prediction with a covariance of 1e21.
inline constexpr double kMaxOdometryStepM = 100;

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_INPUT_BOUNDS_H_
