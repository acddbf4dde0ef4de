#ifndef WAYMARK_SERVER_VISUAL_SLAM_POSE_IO_H_
#define WAYMARK_SERVER_VISUAL_SLAM_POSE_IO_H_

// Poses in the visual session's checkpoint (VisualOdometry and its LocalMap): 12 doubles, R row
// by row then t; a pose read back must be finite.

#include "server/common/binary_io.h"
#include "server/visual_slam/types.h"

namespace waymark::visual_slam {

inline void PutPose(BinaryWriter& out, const Pose& pose) {
  for (int i = 0; i < 9; ++i) out.Put<double>(pose.R(i / 3, i % 3));
  for (int i = 0; i < 3; ++i) out.Put<double>(pose.t(i));
}

inline bool GetPose(BinaryReader& in, Pose* pose) {
  for (int i = 0; i < 9; ++i) {
    if (!in.Get(&pose->R(i / 3, i % 3))) return false;
  }
  for (int i = 0; i < 3; ++i) {
    if (!in.Get(&pose->t(i))) return false;
  }
  return IsFinite(*pose);
}

}  // namespace waymark::visual_slam

#endif  // WAYMARK_SERVER_VISUAL_SLAM_POSE_IO_H_
