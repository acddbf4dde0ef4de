#ifndef WAYMARK_SERVER_VISUAL_SLAM_GEOMETRY_POSE_ALGEBRA_H_
#define WAYMARK_SERVER_VISUAL_SLAM_GEOMETRY_POSE_ALGEBRA_H_

// Conversions between camera poses in the world (Pose: X_w = R X_c + t) and motions between two
// cameras (Motion: X_c = R X_r + t), as the pipeline chains them.

#include "server/visual_slam/types.h"

namespace waymark::visual_slam {

// The motion from the camera at `reference` to the camera at `current`.
inline Motion MotionBetween(const Pose& reference, const Pose& current) {
  Motion m;
  m.R = current.R.transpose() * reference.R;
  m.t = current.R.transpose() * (reference.t - current.t);
  return m;
}

// The pose of a camera that moved by `motion` from `reference`.
inline Pose PoseAfter(const Pose& reference, const Motion& motion) {
  Pose p;
  p.R = reference.R * motion.R.transpose();
  p.t = reference.t - p.R * motion.t;
  return p;
}

inline double RotationAngle(const Eigen::Matrix3d& R) { return Eigen::AngleAxisd(R).angle(); }

}  // namespace waymark::visual_slam

#endif  // WAYMARK_SERVER_VISUAL_SLAM_GEOMETRY_POSE_ALGEBRA_H_
