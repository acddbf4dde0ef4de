#ifndef WAYMARK_SERVER_LASER_SLAM_INPUT_BOUNDS_H_
#define WAYMARK_SERVER_LASER_SLAM_INPUT_BOUNDS_H_

// What the laser engine accepts as physically meaningful. Beyond these a number is a corrupt
// message, not a measurement: odometry of x = 1e300 used to be accepted (only NaN and inf were
// checked) and filled the session's pose and covariance with inf and NaN.

#include <cmath>

#include "server/common/input_bounds.h"  // kMaxAbsStampS, PlausibleStamp
#include "server/laser_slam/types.h"

namespace waymark::laser_slam {

// Odometry coordinates: 1000 km from the base's odometry origin.
inline constexpr double kMaxAbsOdometryM = 1e6;
// Odometry heading, unwrapped (a base may count turns): about 1600 turns.
inline constexpr double kMaxAbsOdometryRad = 1e4;
// Odometry travel between two processed scans. A larger jump is a reset of the base's odometry
// (a reboot, a wrapped counter), not a motion: the scan is processed with no motion and the
// answer says so (ScanUpdate::odometry_reset), instead of a prediction with a covariance of 1e21.
inline constexpr double kMaxOdometryStepM = 100;

// What a checkpoint of the back end may hold (the pose graph's and the localizer's,
// server/laser_slam/mapping): far beyond anything a session reaches, so that only corrupt bytes are
// refused. A stored scan point of -5e37 m made the loop search convert a float beyond the
// integers' range to a grid index (undefined behaviour; found by make fuzz).
// Map-frame poses and corrections: ten times the odometry's bounds.
inline constexpr double kMaxAbsMapM = 10 * kMaxAbsOdometryM;
inline constexpr double kMaxAbsMapRad = 10 * kMaxAbsOdometryRad;
// A scan point in the robot's frame: the longest max_range (100 m) plus the laser's offset on the
// robot (at most 100 m), with room to spare.
inline constexpr double kMaxAbsRobotPointM = 1e4;

// Within the bounds above (NaN and inf are not).
inline bool PlausibleMapPose(const Pose2& p) {
  return std::abs(p.x) <= kMaxAbsMapM && std::abs(p.y) <= kMaxAbsMapM &&
         std::abs(p.theta) <= kMaxAbsMapRad;
}
inline bool PlausibleRobotPoint(double x, double y) {
  return std::abs(x) <= kMaxAbsRobotPointM && std::abs(y) <= kMaxAbsRobotPointM;
}

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_INPUT_BOUNDS_H_
