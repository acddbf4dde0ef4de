#ifndef WAYMARK_SERVER_LASER_SLAM_SEGMENT_EKF_H_
#define WAYMARK_SERVER_LASER_SLAM_SEGMENT_EKF_H_

// The SP-model EKF over the robot and the map segments (METHODS.md section 2): odometry
// prediction, nearest-neighbour association under the Mahalanobis distance of the implicit
// line-coincidence measurement with a chi-square gate and an overlap test, batch update, centering,
// endpoint insertion and extension, state augmentation and segment merging.

#include <array>
#include <cstdint>
#include <vector>

#include <Eigen/Core>

#include "server/laser_slam/options.h"
#include "server/laser_slam/sp_state.h"
#include "server/laser_slam/types.h"

namespace waymark::laser_slam {

struct ObserveStats {
  int matched = 0;
  int added = 0;
  int merged = 0;
  int pruned = 0;  // tentative segments that were never confirmed
  int frozen = 0;  // segments that left the active window
  bool map_changed = false;
  double association_ms = 0.0;
  double update_ms = 0.0;
};

class SegmentEkf {
 public:
  explicit SegmentEkf(const EkfOptions& options);

  // Moves the robot by the odometry increment `u` (robot frame) with error covariance `noise`.
  void Predict(const Pose2& u, const Eigen::Matrix3d& noise);

  // Fuses the segments of one scan, given in the laser frame at `laser_pose` on the robot.
  ObserveStats Observe(const std::vector<ObservedSegment>& observed_in, const Pose2& laser_pose,
                       std::uint64_t scan_index);

  // Merges map segments that are the same wall; returns how many were merged away.
  int MergeSegments(std::uint64_t scan_index);

  SpState& state() { return state_; }
  const SpState& state() const { return state_; }
  std::uint64_t next_segment_id() const { return next_id_; }
  void set_next_segment_id(std::uint64_t id) { next_id_ = id; }

  // A copy to go back to (LaserSlam::AddScan keeps one before every scan): `backup` takes this
  // filter with half its covariance (the lower triangle; the covariance is symmetric to the
  // bit), and RestoreFrom makes this filter what it was, the upper triangle mirrored back.
  // Copying the whole covariance was 2.6 % of a server's time on MIT CSAIL.
  void CopyForRollback(SegmentEkf* backup) const;
  void RestoreFrom(const SegmentEkf& backup);

 private:
  struct Match;
  struct Row;
  // One block of a block-diagonal covariance transform: dofs (up to 3) and their Jacobian.
  struct Transform {
    int size = 0;
    std::array<int, 3> dofs{};
    Eigen::Matrix3d q = Eigen::Matrix3d::Identity();
  };

  std::vector<int> NearbySegments(double radius) const;
  bool Associate(const ObservedSegment& obs, const Pose2& in_robot,
                 const std::vector<int>& candidates, Match* match) const;
  void AppendRows(const Match& match, std::vector<Row>* rows) const;
  // Applies a batch of measurement rows (innovation, sparse state Jacobian, noise); false if the
  // innovation covariance is not positive definite (nothing changes then).
  bool Update(const std::vector<Row>& rows, const Eigen::MatrixXd& noise);
  // Moves the estimates by the correction and resets it to zero (the SP model's centering).
  void Center(const Eigen::VectorXd& correction);
  void ApplyToCovariance(const std::vector<int>& dofs, const Eigen::MatrixXd& q);
  void TransformColumns(const std::vector<Transform>& transforms);
  void ApplyTransforms(const std::vector<Transform>& transforms);
  // The upper triangle of Q C for the block-diagonal Q of `transforms` (ApplyTransforms' second
  // pass; the lower triangle is left stale).
  void TransformRowsOfUpper(const std::vector<Transform>& transforms);
  // Copies the covariance's lower triangle onto its upper one (exact symmetry).
  void MirrorLower();
  // Moves the frame back to the midpoint when it drifted far; returns the shift (0 = none).
  double MidpointShift(SegmentEntity& segment);
  void Recentre(SegmentEntity& segment);
  bool AdjustEndpoints(const Match& match);
  void AddSegment(const ObservedSegment& obs, const Pose2& in_robot, std::uint64_t scan_index);
  bool MergePair(int keep, int drop);
  int PruneTentative(std::uint64_t scan_index);
  int FreezeOutsideWindow(std::uint64_t scan_index);

  EkfOptions options_;
  SpState state_;
  std::uint64_t next_id_ = 1;
};

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_SEGMENT_EKF_H_
