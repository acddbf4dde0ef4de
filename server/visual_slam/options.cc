#include "server/visual_slam/options.h"

#include <cmath>
#include <string>

#include "absl/strings/str_cat.h"

namespace waymark::visual_slam {
namespace {

absl::Status Positive(const char* name, double value) {
  if (std::isfinite(value) && value > 0) return absl::OkStatus();
  return absl::InvalidArgumentError(absl::StrCat(name, " must be a positive number, got ", value));
}

absl::Status InRange(const char* name, double value, double lo, double hi) {
  if (std::isfinite(value) && value >= lo && value <= hi) return absl::OkStatus();
  return absl::InvalidArgumentError(
      absl::StrCat(name, " must be in [", lo, ", ", hi, "], got ", value));
}

}  // namespace

absl::Status VisualOdometryOptions::Validate() const {
  const absl::Status checks[] = {
      InRange("orb.features", orb.features, 50, 20000),
      InRange("orb.scale_factor", orb.scale_factor, 1.01, 2.0),
      InRange("orb.levels", orb.levels, 1, 16),
      InRange("orb.fast_threshold", orb.fast_threshold, 1, 255),
      InRange("sampler.b1", sampler.b1, 0, 1),
      InRange("sampler.b2", sampler.b2, 0, 1),
      InRange("sampler.lambda1", sampler.lambda1, 0, 1e6),
      InRange("sampler.lambda2", sampler.lambda2, 0, 1e6),
      InRange("sampler.tie_break_fraction", sampler.tie_break_fraction, 0, 1),
      InRange("sampler.max_rounds", sampler.max_rounds, 1, 100),
      InRange("sampler.hypotheses_per_round", sampler.hypotheses_per_round, 1, 10000),
      InRange("sampler.unpredicted_factor", sampler.unpredicted_factor, 1, 100),
      InRange("delta", delta, 1, 256),
      InRange("match_ratio", match_ratio, 0.1, 1.0),
      Positive("static_distance_px", static_distance_px),
      InRange("static_hamming_fraction", static_hamming_fraction, 0.01, 1),
      InRange("proven_static_frames", proven_static_frames, 1, 1000),
      Positive("inlier_threshold_px", inlier_threshold_px),
      Positive("depth_scale", depth_scale),
      Positive("min_depth", min_depth),
      Positive("max_depth", max_depth),
      InRange("min_tracked", min_tracked, 6, 10000),
      InRange("keyframe_tracked_fraction", keyframe_tracked_fraction, 0, 1),
      Positive("keyframe_distance", keyframe_distance),
      Positive("keyframe_angle", keyframe_angle),
      InRange("local_map_keyframes", local_map_keyframes, 1, 50),
      InRange("bundle_window", bundle_window, 0, 50),
      InRange("relocalization_keyframes", relocalization_keyframes, 0, 1000),
      InRange("prior_direction_deg", prior_direction_deg, 0, 180),
      InRange("prior_rotation_deg", prior_rotation_deg, 0, 180),
      InRange("prior_inlier_fraction", prior_inlier_fraction, 0, 10),
  };
  for (const absl::Status& status : checks) {
    if (!status.ok()) return status;
  }
  if (bundle_window > 0 && bundle_window < 3) {
    return absl::InvalidArgumentError(absl::StrCat(
        "bundle_window must be 0 (off) or at least 3 (two keyframes fix a monocular gauge), got ",
        bundle_window));
  }
  if (min_depth >= max_depth) {
    return absl::InvalidArgumentError(
        absl::StrCat("min_depth (", min_depth, ") must be below max_depth (", max_depth, ")"));
  }
  return absl::OkStatus();
}

VisualOdometryOptions VisualOdometryOptions::MeasuredBest() {
  VisualOdometryOptions o;
  o.filter = DynamicFilter::kProven;
  o.static_hamming_fraction = 1.0;
  o.proven_static_frames = 2;
  o.join_static_boxed = true;  // issue 35: boxed static pairs join the polish and the window now
  o.prior_direction_deg = 30;  // monocular only (the engine applies it to monocular sessions)
  o.bundle_window = 10;
  o.bundle_monocular_only = true;
  return o;
}

VisualOdometryOptions OptionsForPreset(Preset preset) {
  return preset == Preset::kPaper ? VisualOdometryOptions::Paper()
                                  : VisualOdometryOptions::MeasuredBest();
}

const char* PresetName(Preset preset) {
  return preset == Preset::kPaper ? "paper" : "measured-best";
}

}  // namespace waymark::visual_slam
