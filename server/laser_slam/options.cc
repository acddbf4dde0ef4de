#include "server/laser_slam/options.h"

#include <cmath>

#include "absl/strings/str_cat.h"
#include "server/laser_slam/geometry.h"
#include "server/laser_slam/option_checks.h"

namespace waymark::laser_slam {
namespace {


}  // namespace

absl::Status ValidateSlamOptions(const SlamOptions& options) {
  const LineExtractionOptions& e = options.extraction;
  for (absl::Status s : {Positive(e.max_range, "max_range"), NonNegative(e.min_range, "min_range"),
                         Positive(e.range_sigma, "range_sigma"),
                         NonNegative(e.bearing_sigma, "bearing_sigma"),
                         Positive(e.discontinuity_abs, "discontinuity_abs"),
                         NonNegative(e.discontinuity_rel, "discontinuity_rel"),
                         Positive(e.split_distance, "split_distance"),
                         NonNegative(e.min_length, "min_length"),
                         NonNegative(e.min_incidence, "min_incidence"),
                         NonNegative(e.merge_angle, "merge_angle"),
                         NonNegative(e.merge_distance, "merge_distance")}) {
    if (!s.ok()) return s;
  }
  if (e.min_range >= e.max_range) {
    return absl::InvalidArgumentError("min_range must be below max_range");
  }
  if (e.min_points < 2) return absl::InvalidArgumentError("min_points must be at least 2");
  const OdometryNoise& o = options.odometry;
  for (absl::Status s : {NonNegative(o.xy_per_m, "odom_xy_per_m"),
                         NonNegative(o.theta_per_rad, "odom_theta_per_rad"),
                         NonNegative(o.theta_per_m, "odom_theta_per_m"),
                         Positive(o.xy_min, "odom_xy_min"), Positive(o.theta_min, "odom_theta_min")}) {
    if (!s.ok()) return s;
  }
  const EkfOptions& k = options.ekf;
  for (absl::Status s : {Positive(k.match_chi2, "match_chi2"),
                         NonNegative(k.overlap_margin, "overlap_margin"),
                         Positive(k.endpoint_chi2, "endpoint_chi2"),
                         Positive(k.merge_chi2, "merge_chi2"), NonNegative(k.merge_gap, "merge_gap"),
                         Positive(k.association_radius, "association_radius"),
                         NonNegative(k.min_travel, "min_travel"),
                         NonNegative(k.min_turn, "min_turn")}) {
    if (!s.ok()) return s;
  }
  if (k.confirm_observations < 1 || k.confirm_window < 1) {
    return absl::InvalidArgumentError("confirm_observations and confirm_window must be >= 1");
  }
  if (!(k.active_radius > k.association_radius)) {
    return absl::InvalidArgumentError("active_radius must exceed association_radius");
  }
  if (k.freeze_after_scans < 1 || k.max_active_segments < 10) {
    return absl::InvalidArgumentError(
        "freeze_after_scans must be >= 1 and max_active_segments >= 10");
  }
  if (k.merge_every_scans < 0) return absl::InvalidArgumentError("merge_every_scans must be >= 0");
  if (!FinitePose(options.laser_pose)) {
    return absl::InvalidArgumentError("laser_pose must be finite");
  }
  if (absl::Status s = ValidateExplorationOptions(options.exploration); !s.ok()) return s;
  return ValidateMappingOptions(options.mapping);
}

absl::Status ValidateScanGeometry(const ScanGeometry& geometry) {
  if (geometry.beam_count < 2 || geometry.beam_count > 10000) {
    return absl::InvalidArgumentError(
        absl::StrCat("beam_count must be in [2, 10000], got ", geometry.beam_count));
  }
  if (!std::isfinite(geometry.angle_min) || std::abs(geometry.angle_min) > 2 * M_PI) {
    return absl::InvalidArgumentError(
        absl::StrCat("angle_min must be finite and within +-2 pi, got ", geometry.angle_min));
  }
  if (!std::isfinite(geometry.angle_increment) || geometry.angle_increment == 0.0 ||
      std::abs(geometry.angle_increment * (geometry.beam_count - 1)) > 2 * M_PI + 1e-6) {
    return absl::InvalidArgumentError(absl::StrCat(
        "angle_increment must be non-zero and the beams must span at most 2 pi, got ",
        geometry.angle_increment, " rad x ", geometry.beam_count, " beams"));
  }
  if (!std::isfinite(geometry.no_return_range) || geometry.no_return_range < 0.0) {
    return absl::InvalidArgumentError("no_return_range must be >= 0 (0 = none)");
  }
  return absl::OkStatus();
}

}  // namespace waymark::laser_slam
