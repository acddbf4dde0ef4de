#include "client/eval/trajectory_metrics.h"

#include <fmt/format.h>

#include <Eigen/LU>
#include <Eigen/SVD>
#include <algorithm>
#include <cmath>
#include <numeric>
#include <tuple>

#include "absl/status/status.h"

namespace waymark::cli {
namespace {

constexpr double kRadToDeg = 57.295779513082320876798;

}  // namespace

StampSpan SpanOf(const std::vector<StampedPose3>& poses) {
  StampSpan span;
  span.poses = poses.size();
  if (poses.empty()) return span;
  span.first = span.last = poses.front().stamp;
  for (const StampedPose3& p : poses) {
    span.first = std::min(span.first, p.stamp);
    span.last = std::max(span.last, p.stamp);
  }
  return span;
}

std::string FormatStampSpan(const StampSpan& span) {
  if (span.poses == 0) return "no poses";
  return fmt::format("{} poses, stamps {:.6f} .. {:.6f}", span.poses, span.first, span.last);
}

std::optional<std::string> FewMatchesWarning(const TrajectoryEvaluation& e) {
  const size_t shorter = std::min(e.poses_estimated, e.poses_groundtruth);
  if (static_cast<double>(e.matches.size()) >= kFewMatchesShare * static_cast<double>(shorter)) {
    return std::nullopt;
  }
  return fmt::format(
      "only {} of {} poses matched by stamp (fewer than half of the shorter trajectory), so the "
      "errors describe a few poses, not the run: estimate has {}, ground truth has {}; check that "
      "both use the same time base (KITTI poses without a times.txt are at 0.1 * i s)",
      e.matches.size(), shorter, FormatStampSpan(e.estimate_span),
      FormatStampSpan(e.groundtruth_span));
}

absl::StatusOr<Similarity3> AlignUmeyama(const std::vector<Eigen::Vector3d>& source,
                                         const std::vector<Eigen::Vector3d>& target,
                                         bool with_scale) {
  if (source.size() != target.size()) {
    return absl::InvalidArgumentError(
        fmt::format("alignment needs point pairs: {} source and {} target points", source.size(),
                    target.size()));
  }
  const size_t n = source.size();
  if (n < 3) {
    return absl::FailedPreconditionError(
        fmt::format("alignment needs at least 3 point pairs, got {}", n));
  }
  Eigen::Vector3d mean_source = Eigen::Vector3d::Zero();
  Eigen::Vector3d mean_target = Eigen::Vector3d::Zero();
  for (size_t i = 0; i < n; ++i) {
    mean_source += source[i];
    mean_target += target[i];
  }
  mean_source /= static_cast<double>(n);
  mean_target /= static_cast<double>(n);

  // Cross-covariance Sigma = 1/n sum (y - mu_y)(x - mu_x)^T and the source variance.
  Eigen::Matrix3d sigma = Eigen::Matrix3d::Zero();
  double variance_source = 0;
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d x = source[i] - mean_source;
    const Eigen::Vector3d y = target[i] - mean_target;
    sigma += y * x.transpose();
    variance_source += x.squaredNorm();
  }
  sigma /= static_cast<double>(n);
  variance_source /= static_cast<double>(n);

  Eigen::JacobiSVD<Eigen::Matrix3d> svd(sigma, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d s = Eigen::Matrix3d::Identity();
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0) s(2, 2) = -1;  // no mirror

  Similarity3 result;
  result.rotation = svd.matrixU() * s * svd.matrixV().transpose();
  if (with_scale) {
    if (!(variance_source > 1e-24)) {
      return absl::FailedPreconditionError(
          "scale alignment needs estimated positions that are not all the same point");
    }
    result.scale = (svd.singularValues().asDiagonal() * s).trace() / variance_source;
  }
  result.translation = mean_target - result.scale * result.rotation * mean_source;
  return result;
}

ErrorStats ComputeErrorStats(std::vector<double> errors) {
  ErrorStats stats;
  stats.count = errors.size();
  if (errors.empty()) return stats;
  double sum = 0;
  double sum_sq = 0;
  for (double e : errors) {
    sum += e;
    sum_sq += e * e;
    stats.max = std::max(stats.max, e);
  }
  const double n = static_cast<double>(errors.size());
  stats.mean = sum / n;
  stats.rmse = std::sqrt(sum_sq / n);
  double var = 0;
  for (double e : errors) var += (e - stats.mean) * (e - stats.mean);
  stats.std = std::sqrt(var / n);
  std::sort(errors.begin(), errors.end());
  const size_t mid = errors.size() / 2;
  stats.median = errors.size() % 2 == 1 ? errors[mid] : 0.5 * (errors[mid - 1] + errors[mid]);
  return stats;
}

double RotationAngle(const Eigen::Matrix3d& rotation) {
  // atan2(sin, cos) keeps small angles precise, where acos of the trace loses half the digits.
  const Eigen::Vector3d axis(rotation(2, 1) - rotation(1, 2), rotation(0, 2) - rotation(2, 0),
                             rotation(1, 0) - rotation(0, 1));
  return std::atan2(0.5 * axis.norm(), 0.5 * (rotation.trace() - 1.0));
}

absl::StatusOr<TrajectoryEvaluation> EvaluateTrajectory(
    const std::vector<StampedPose3>& estimate, const std::vector<StampedPose3>& groundtruth,
    const TrajectoryOptions& options) {
  if (!(options.max_dt >= 0) || !std::isfinite(options.max_dt)) {
    return absl::InvalidArgumentError("max_dt must be a finite number >= 0");
  }
  if (options.delta < 1) return absl::InvalidArgumentError("delta must be at least 1");

  TrajectoryEvaluation result;
  result.poses_estimated = estimate.size();
  result.poses_groundtruth = groundtruth.size();
  result.estimate_span = SpanOf(estimate);
  result.groundtruth_span = SpanOf(groundtruth);
  std::vector<double> est_stamps;
  std::vector<double> gt_stamps;
  for (const StampedPose3& p : estimate) est_stamps.push_back(p.stamp);
  for (const StampedPose3& p : groundtruth) gt_stamps.push_back(p.stamp);
  result.matches = AssociateByStamp(est_stamps, gt_stamps, options.max_dt);
  if (result.matches.size() < 3) {
    return absl::FailedPreconditionError(fmt::format(
        "only {} poses matched within {} s (at least 3 needed): estimate has {}, ground truth has "
        "{}",
        result.matches.size(), options.max_dt, FormatStampSpan(result.estimate_span),
        FormatStampSpan(result.groundtruth_span)));
  }

  std::vector<Eigen::Vector3d> source;
  std::vector<Eigen::Vector3d> target;
  for (const PoseMatch& m : result.matches) {
    source.push_back(estimate[m.estimate].translation);
    target.push_back(groundtruth[m.groundtruth].translation);
  }
  absl::StatusOr<Similarity3> alignment = AlignUmeyama(source, target, options.with_scale);
  if (!alignment.ok()) return alignment.status();
  result.alignment = *alignment;

  // ATE: translation error of every aligned position.
  std::vector<double> ate;
  std::vector<StampedPose3> aligned;  // matched estimates in the ground-truth frame
  for (size_t k = 0; k < source.size(); ++k) {
    const Eigen::Vector3d p = alignment->Apply(source[k]);
    result.aligned_positions.push_back(p);
    result.groundtruth_positions.push_back(target[k]);
    result.groundtruth_rotations.push_back(groundtruth[result.matches[k].groundtruth].rotation);
    ate.push_back((p - target[k]).norm());
    StampedPose3 a = estimate[result.matches[k].estimate];
    a.rotation = alignment->rotation * a.rotation;
    a.translation = p;
    aligned.push_back(a);
  }
  result.ate = ComputeErrorStats(std::move(ate));

  // RPE: E = (G_i^-1 G_j)^-1 (A_i^-1 A_j) for j = i + delta over the matched poses.
  std::vector<double> rpe_t;
  std::vector<double> rpe_r;
  const size_t delta = static_cast<size_t>(options.delta);
  for (size_t i = 0; i + delta < aligned.size(); ++i) {
    const size_t j = i + delta;
    const StampedPose3& gi = groundtruth[result.matches[i].groundtruth];
    const StampedPose3& gj = groundtruth[result.matches[j].groundtruth];
    const Eigen::Matrix3d gt_r = gi.rotation.transpose() * gj.rotation;
    const Eigen::Vector3d gt_t = gi.rotation.transpose() * (gj.translation - gi.translation);
    const Eigen::Matrix3d est_r = aligned[i].rotation.transpose() * aligned[j].rotation;
    const Eigen::Vector3d est_t =
        aligned[i].rotation.transpose() * (aligned[j].translation - aligned[i].translation);
    const Eigen::Matrix3d err_r = gt_r.transpose() * est_r;
    const Eigen::Vector3d err_t = gt_r.transpose() * (est_t - gt_t);
    rpe_t.push_back(err_t.norm());
    rpe_r.push_back(RotationAngle(err_r) * kRadToDeg);
  }
  result.rpe_translation = ComputeErrorStats(std::move(rpe_t));
  result.rpe_rotation_deg = ComputeErrorStats(std::move(rpe_r));
  return result;
}

}  // namespace waymark::cli
