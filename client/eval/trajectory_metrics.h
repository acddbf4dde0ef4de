#ifndef WAYMARK_CLIENT_EVAL_TRAJECTORY_METRICS_H_
#define WAYMARK_CLIENT_EVAL_TRAJECTORY_METRICS_H_

// Visual odometry accuracy (DESIGN.md, evaluation protocols; the TUM RGB-D benchmark's tools):
// association of an estimated trajectory with ground truth by time stamp, the absolute trajectory
// error (ATE) after a closed-form rigid (Horn / Umeyama) or similarity alignment, and the relative
// pose error (RPE) over consecutive matched poses. Pure math: no I/O (pose_file.h reads files).

#include <Eigen/Core>
#include <cstddef>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "client/datasets/stamp_association.h"
#include "client/datasets/stamped_pose3.h"

namespace waymark::cli {

// x -> scale * rotation * x + translation (scale 1 for a rigid transform).
struct Similarity3 {
  Eigen::Matrix3d rotation = Eigen::Matrix3d::Identity();
  Eigen::Vector3d translation = Eigen::Vector3d::Zero();
  double scale = 1;

  Eigen::Vector3d Apply(const Eigen::Vector3d& x) const {
    return scale * rotation * x + translation;
  }
};

// The transform that best maps `source` onto `target` in the least-squares sense (Umeyama 1991,
// the closed form of Horn's method): SVD of the cross-covariance, with the determinant fix so the
// rotation is proper. `with_scale` also estimates the scale (Sim(3), for monocular trajectories).
// FAILED_PRECONDITION for fewer than 3 pairs or (with scale) a source without spread;
// INVALID_ARGUMENT for different sizes.
absl::StatusOr<Similarity3> AlignUmeyama(const std::vector<Eigen::Vector3d>& source,
                                         const std::vector<Eigen::Vector3d>& target,
                                         bool with_scale);

struct ErrorStats {
  size_t count = 0;
  double rmse = 0;
  double mean = 0;
  double median = 0;
  double std = 0;  // population standard deviation (numpy.std, as the TUM tools)
  double max = 0;
};
// All zero for an empty input.
ErrorStats ComputeErrorStats(std::vector<double> errors);

// Rotation angle of a rotation matrix in radians, in [0, pi] (robust to rounding).
double RotationAngle(const Eigen::Matrix3d& rotation);

struct TrajectoryOptions {
  double max_dt = 0.02;     // s: largest stamp difference of a match
  bool with_scale = false;  // Sim(3) alignment instead of SE(3)
  int delta = 1;            // RPE: pose pairs (k, k + delta) over the matched poses
};

// The stamps a trajectory spans (for messages that say why poses did not match).
struct StampSpan {
  size_t poses = 0;
  double first = 0;  // s; smallest stamp
  double last = 0;   // s; largest stamp
};
StampSpan SpanOf(const std::vector<StampedPose3>& poses);
// "51 poses, stamps 0.000000 .. 5.000000" ("no poses" for an empty span).
std::string FormatStampSpan(const StampSpan& span);

struct TrajectoryEvaluation {
  size_t poses_estimated = 0;
  size_t poses_groundtruth = 0;
  StampSpan estimate_span;
  StampSpan groundtruth_span;
  std::vector<PoseMatch> matches;  // ordered by estimated stamp
  Similarity3 alignment;           // estimate -> ground-truth frame
  ErrorStats ate;                  // m, translation error of the aligned estimate
  ErrorStats rpe_translation;      // m (estimate scaled by alignment.scale)
  ErrorStats rpe_rotation_deg;     // degrees
  // Positions of the matched poses, ground truth and aligned estimate (for plots).
  std::vector<Eigen::Vector3d> groundtruth_positions;
  std::vector<Eigen::Vector3d> aligned_positions;
  std::vector<Eigen::Matrix3d> groundtruth_rotations;  // of the matched poses
};

// ATE and RPE of `estimate` against `groundtruth`. FAILED_PRECONDITION when fewer than 3 poses
// match (the message gives the count and both stamp ranges); INVALID_ARGUMENT for bad options.
absl::StatusOr<TrajectoryEvaluation> EvaluateTrajectory(
    const std::vector<StampedPose3>& estimate, const std::vector<StampedPose3>& groundtruth,
    const TrajectoryOptions& options = {});

// Below this share of the shorter trajectory's poses matched, an evaluation is suspect: the two
// files most likely use different time bases (a KITTI file read with another rule than the one
// its partner was stamped with, a ground truth of another part of the sequence), and the ATE
// describes a few poses, not the run.
inline constexpr double kFewMatchesShare = 0.5;

// A warning naming the match count and both stamp spans when fewer than kFewMatchesShare of the
// shorter trajectory's poses matched; nullopt otherwise.
std::optional<std::string> FewMatchesWarning(const TrajectoryEvaluation& evaluation);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_EVAL_TRAJECTORY_METRICS_H_
