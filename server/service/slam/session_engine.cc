#include "server/service/slam/session_engine.h"

namespace waymark::service {

v1::TrajectoryPose TrajectoryPoseFromRecord(const storage::TrajectoryPoseRecord& record) {
  v1::TrajectoryPose out;
  out.set_stamp(record.stamp);
  if (record.pose3.has_value()) {
    v1::Pose3D* pose = out.mutable_pose3d();
    pose->set_x(record.x);
    pose->set_y(record.y);
    pose->set_z(record.pose3->z);
    pose->set_qx(record.pose3->qx);
    pose->set_qy(record.pose3->qy);
    pose->set_qz(record.pose3->qz);
    pose->set_qw(record.pose3->qw);
    return out;
  }
  out.mutable_pose()->set_x(record.x);
  out.mutable_pose()->set_y(record.y);
  out.mutable_pose()->set_theta(record.theta);
  for (double value : record.covariance) out.add_covariance(value);
  return out;
}

}  // namespace waymark::service
