#ifndef WAYMARK_SERVER_LASER_SLAM_MAPPING_EKF_STEP_AGREEMENT_H_
#define WAYMARK_SERVER_LASER_SLAM_MAPPING_EKF_STEP_AGREEMENT_H_

// How good the EKF's steps are, learned over a session from the local matches (issue 33).
//
// Local matching fuses two estimates of each step between nodes: the EKF's and the scan match's.
// How much the EKF's deserves depends on where the robot is: in a world of straight walls (the
// simulator) the paper's segment EKF is right to 5 mm a step and the matches are 4x worse, while
// on real logs its steps are no better than the odometry (a wrong association now and then), and
// the matches are the better half. Neither the EKF's own covariance nor the odometry model says
// which: both describe the case where every association is right.
//
// The matches do. A match does not depend on the EKF's step (the step only centres its window),
// so over many steps the mean of (EKF - match)^2 on an axis is the EKF step's variance plus the
// match's; the match's own variance (the inverse curvature of its score, local_matcher.h) taken
// away leaves the EKF's. The statistics forget with a memory of kMemorySteps steps, so that a
// robot that leaves a building of straight walls for a car park stops trusting its EKF there.
// Only steps whose match carries information on the axis enter that axis (along a corridor
// without ends the match knows nothing of the distance, and its variance there is no estimate of
// anything), and only matches whose best pose lies inside their search window (on its edge the
// score may still be rising beyond it: MatchLocally ignores such a match's translation).

#include <cstdint>
#include <optional>

#include <Eigen/Core>

namespace waymark::laser_slam {

class EkfStepAgreement {
 public:
  // Steps an axis needs before its variance is given: fewer say little about a mean of squares.
  static constexpr double kMinSteps = 10.0;
  // The forgetting memory, in steps (an exponential window).
  static constexpr double kMemorySteps = 100.0;

  // One step's disagreement, EKF minus match per axis (x, y in metres, theta in radians), and the
  // match's own variance per axis; axes where `informative` is false are not recorded.
  void Add(const Eigen::Vector3d& ekf_minus_match, const Eigen::Vector3d& match_variance,
           const Eigen::Array3i& informative);

  // The EKF step's variance on `axis` as the matches see it (at least `floor`), once the axis
  // has kMinSteps steps; nullopt before.
  std::optional<double> EkfVariance(int axis, double floor) const;
  // The matches' own mean variance on `axis` (same condition).
  std::optional<double> MatchVariance(int axis) const;
  // The EKF's steps and the matches disagree on `axis` by more than chance allows: their mean
  // difference lies beyond `sigmas` standard errors of it (the steps' own spread). One of them is
  // biased, and a bias that a single step hides adds up along a corridor: on the noisy-odometry
  // freiburg-campus log the EKF's heading ran 12 mrad a step behind the matches (t = -12), the
  // wheels' rotational bias carried through. True before kMinSteps (nothing is known yet).
  bool Biased(int axis, double sigmas) const;

  // The state, for the back end's checkpoint: 12 numbers (sums and counts per axis).
  static constexpr int kValues = 12;
  void Values(double (&values)[kValues]) const;
  // nullopt when the numbers could not have come from Values (negative, not finite).
  static std::optional<EkfStepAgreement> FromValues(const double (&values)[kValues]);

 private:
  Eigen::Array3d difference_ = Eigen::Array3d::Zero();    // weighted sums of E - M
  Eigen::Array3d disagreement_ = Eigen::Array3d::Zero();  // weighted sums of (E - M)^2
  Eigen::Array3d match_ = Eigen::Array3d::Zero();         // weighted sums of the match variance
  Eigen::Array3d weight_ = Eigen::Array3d::Zero();        // weighted counts
};

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_MAPPING_EKF_STEP_AGREEMENT_H_
