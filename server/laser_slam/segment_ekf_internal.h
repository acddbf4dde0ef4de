#ifndef WAYMARK_SERVER_LASER_SLAM_SEGMENT_EKF_INTERNAL_H_
#define WAYMARK_SERVER_LASER_SLAM_SEGMENT_EKF_INTERNAL_H_

// What segment_ekf.cc (the filter) and segment_ekf_upkeep.cc (the map's upkeep) share: the
// association's pre-filters and the filter's private match and measurement-row types. Not for
// any other file.

#include <array>

#include <Eigen/Core>

#include "server/laser_slam/segment_ekf.h"
#include "server/laser_slam/sp_jacobians.h"

namespace waymark::laser_slam {

// Cheap pre-filters before the Mahalanobis test (ours): a match needs the lines within this angle
// and the observed midpoint within this distance of the map line. Far looser than any gate.
inline constexpr double kMaxMatchAngle = 0.5;     // rad
inline constexpr double kMaxMatchOffset = 1.5;    // m

struct SegmentEkf::Match {
  int segment = -1;       // position in state_.segments
  ObservedSegment obs;    // aligned with the map segment's direction
  Pose2 in_robot;         // obs.frame on the robot
  RelativeLine rel;
  double distance = 0.0;  // Mahalanobis
};

// One scalar measurement row: innovation, Jacobian w.r.t. state dofs (sparse) and w.r.t. the
// match's observation noise vector [c_y, c_theta, q_l, q_r].
struct SegmentEkf::Row {
  double innovation = 0.0;
  int count = 0;
  std::array<int, 6> dof{};
  std::array<double, 6> value{};
  Eigen::Matrix<double, 1, 4> noise_jacobian = Eigen::Matrix<double, 1, 4>::Zero();
  int match_block = 0;  // rows of one match share one observation noise vector
  void Add(int d, double v) {
    dof[count] = d;
    value[count] = v;
    ++count;
  }
};

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_SEGMENT_EKF_INTERNAL_H_
