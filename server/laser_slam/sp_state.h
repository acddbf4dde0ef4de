#ifndef WAYMARK_SERVER_LASER_SLAM_SP_STATE_H_
#define WAYMARK_SERVER_LASER_SLAM_SP_STATE_H_

// The stochastic map of the SP model: the location estimates of the robot and of every segment,
// and one covariance over all their perturbation degrees of freedom (METHODS.md section 2).
//
// After centering every perturbation estimate is zero, so the state is just the locations plus
// the covariance. A segment owns a 2-dof line perturbation (p_y, p_theta) and one more dof per
// REAL endpoint (its displacement along the line); virtual endpoints carry none, exactly as the
// binding matrix B_S = rows of [p_y, p_theta, alpha_l p_l, alpha_r p_r] selects.
//
// Degrees of freedom are addressed by index, not by position in a per-entity block: an endpoint
// that turns real appends one index at the end, and removing dofs moves the last ones into the
// holes. Both cost O(n) instead of the O(n^2) of shifting the matrix.

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "server/laser_slam/types.h"

namespace waymark::laser_slam {

struct SegmentEntity {
  std::uint64_t id = 0;
  Pose2 frame;  // location estimate in the map frame: on the line, x along it
  double left = 0.0;
  double right = 0.0;
  EndpointType left_type = EndpointType::kVirtual;
  EndpointType right_type = EndpointType::kVirtual;
  // State indices of the dofs [p_y, p_theta, p_l, p_r]; -1 for an endpoint that is virtual.
  std::array<int, 4> dof = {-1, -1, -1, -1};
  int observations = 0;
  std::uint64_t first_seen_scan = 0;
  std::uint64_t last_seen_scan = 0;
};

// A segment that left the active window: marginalised out of the filter (its last estimate and
// marginal covariance kept for the map, never updated again).
struct FrozenSegment {
  SegmentEntity entity;  // dof indices are meaningless (all -1)
  Eigen::Matrix2d line_covariance = Eigen::Matrix2d::Zero();
  double left_variance = 0.0;
  double right_variance = 0.0;
};

class SpState {
 public:
  SpState();
  SpState(const SpState&) = default;
  // Copies the state into this one's buffers: the first size() rows and columns of the
  // covariance, into storage reused when it is large enough. LaserSlam keeps a copy of the
  // filter before every scan (to go back to if the scan would make it non-finite); copying the
  // whole storage allocated and filled 0.5-2 MB per scan.
  SpState& operator=(const SpState& other);
  // The same with only the covariance's lower triangle (half the bytes; the upper one is left
  // as it was): for a copy kept to go back to, whose covariance is mirrored when it is used.
  void AssignLowerTriangle(const SpState& other);

  int size() const { return n_; }
  // The covariance over all dofs. Only the first size() rows and columns are meaningful.
  Eigen::Block<Eigen::MatrixXd> cov() { return storage_.topLeftCorner(n_, n_); }
  Eigen::Block<const Eigen::MatrixXd> cov() const { return storage_.topLeftCorner(n_, n_); }
  double& at(int i, int j) { return storage_(i, j); }
  double at(int i, int j) const { return storage_(i, j); }

  // Appends `k` dofs (zero covariance rows/columns) and returns the index of the first.
  int AddDofs(int k);
  // Removes the given dofs (never the robot's 0..2); segment dof indices are renumbered.
  void RemoveDofs(std::vector<int> dofs);

  Pose2 robot;  // robot location estimate; dofs 0..2
  std::vector<SegmentEntity> segments;  // in the filter
  std::vector<FrozenSegment> frozen;    // out of it, oldest first

 private:
  void Reserve(int capacity);

  Eigen::MatrixXd storage_;
  int n_ = 0;
};

// Indices of a segment's present dofs in order [p_y, p_theta, (p_l), (p_r)].
std::vector<int> SegmentDofs(const SegmentEntity& segment);

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_SP_STATE_H_
