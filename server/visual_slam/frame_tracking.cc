#include "server/visual_slam/frame_tracking.h"

#include <algorithm>
#include <cmath>

#include "absl/strings/str_cat.h"
#include "server/common/stopwatch.h"
#include "server/visual_slam/geometry/essential_solver.h"
#include "server/visual_slam/geometry/pnp_solver.h"
#include "server/visual_slam/geometry/pose_algebra.h"
#include "server/visual_slam/geometry/sequential_sampler.h"
#include "server/visual_slam/geometry/static_test.h"
#include "server/visual_slam/geometry/two_view.h"

namespace waymark::visual_slam {
namespace {

bool OutsideBoxes(const TrackingInputs& in, const DescriptorMatch& match) {
  return !(*in.current_in_box)[match.query];
}

ReferenceRole RoleOf(const TrackingInputs& in, const DescriptorMatch& match) {
  return in.reference_roles != nullptr ? (*in.reference_roles)[match.train]
                                       : ReferenceRole::kMapped;
}

// Whether the pair of match k may shape the motion model: the paper samples only pairs outside
// every box (eq 9); the plain baseline samples all; kProven also samples features proven static.
bool Samplable(const TrackingInputs& in, const VisualOdometryOptions& options,
               const DescriptorMatch& match) {
  if (options.filter == DynamicFilter::kNone) return true;
  switch (RoleOf(in, match)) {
    case ReferenceRole::kProven:
      return true;
    case ReferenceRole::kCandidate:
      return false;
    case ReferenceRole::kMapped:
      return OutsideBoxes(in, match);
  }
  return false;
}

// Whether a static pair may take part in tracking under the filter: the full method tracks on
// every static feature (parked cars included), the boxes-only filter never uses a boxed one.
bool Trackable(const VisualOdometryOptions& options, bool in_box) {
  return options.filter != DynamicFilter::kBoxesOnly || !in_box;
}

// Matches the frames and builds the correspondences; `with_points` attaches the reference's 3-D
// points (RGB-D).
void MatchFrames(const TrackingInputs& in, const VisualOdometryOptions& options, bool with_points,
                 TrackingOutcome& out) {
  const Clock::time_point start = Clock::now();
  out.matches = in.matches != nullptr
                    ? *in.matches
                    : CoarseMatch(in.current->descriptors, in.reference->descriptors, options.delta,
                                  options.match_ratio);
  out.correspondences.reserve(out.matches.size());
  for (const DescriptorMatch& m : out.matches) {
    Correspondence c;
    c.reference = in.reference->normalized[m.train];
    c.current = in.current->normalized[m.query];
    if (with_points) c.reference_point = in.reference->Point(m.train);
    c.hamming = m.distance;
    out.correspondences.push_back(c);
  }
  out.matching_ms = MsSince(start);
}

// The pairs allowed to shape the motion model (the filter's rule and the solver's).
std::vector<int> SamplablePairs(const MotionSolver& solver, const TrackingInputs& in,
                                const VisualOdometryOptions& options, const TrackingOutcome& out) {
  std::vector<int> pairs;
  for (size_t k = 0; k < out.matches.size(); ++k) {
    if (Samplable(in, options, out.matches[k]) && solver.Samplable(static_cast<int>(k))) {
      pairs.push_back(static_cast<int>(k));
    }
  }
  return pairs;
}

// Runs the sampler over the pairs allowed to shape the model; returns the chosen hypothesis.
std::optional<Hypothesis> SampleMotion(const MotionSolver& solver, const TrackingInputs& in,
                                       const VisualOdometryOptions& options, TrackingOutcome& out) {
  const Clock::time_point start = Clock::now();
  const std::vector<int> candidates = SamplablePairs(solver, in, options, out);
  std::vector<double> eta;
  for (int k : candidates) {
    // Prior inlier probability from the descriptor distance: a close match is likelier right.
    eta.push_back(
        std::clamp(1.0 - out.matches[k].distance / static_cast<double>(options.delta), 0.05, 1.0));
  }
  SamplerOptions sampler = options.sampler;
  // No velocity yet (the first motion, or after a reset) predicts no motion at all: exactly zero.
  if (!in.predicted || in.predicted->t.norm() == 0) {
    sampler.hypotheses_per_round *= sampler.unpredicted_factor;
  }
  SamplerResult result =
      SequentialSample(solver, candidates, eta, in.predicted, options.inlier_threshold_px, sampler);
  out.hypotheses = result.hypotheses;
  out.sampling_ms = MsSince(start);
  if (result.chosen < 0) {
    out.failure = absl::StrCat("no motion hypothesis from ", candidates.size(), " pairs");
    return std::nullopt;
  }
  return result.best[result.chosen];
}

constexpr double kDegreesPerRadian = 180 / 3.14159265358979323846;

double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const double c = a.normalized().dot(b.normalized());
  return std::acos(std::clamp(c, -1.0, 1.0)) * kDegreesPerRadian;
}

// Whether `motion` turns or heads too far from the prediction (options.prior_*).
bool FarFromPrediction(const Motion& motion, const Motion& predicted,
                       const VisualOdometryOptions& options) {
  if (predicted.t.norm() < 1e-9) return false;  // no prediction of a direction
  const double turn = RotationAngle(predicted.R.transpose() * motion.R) * kDegreesPerRadian;
  return AngleDeg(motion.t, predicted.t) > options.prior_direction_deg ||
         turn > options.prior_rotation_deg;
}

// The monocular motion prior: a chosen motion far from the constant-velocity prediction gives
// way to the prediction polished on the samplable pairs it explains, when that is about as
// consistent with them.
void ApplyMotionPrior(const MotionSolver& solver, const TrackingInputs& in,
                      const VisualOdometryOptions& options, const TrackingOutcome& out,
                      Hypothesis& chosen) {
  if (options.prior_direction_deg <= 0 || !in.predicted ||
      !FarFromPrediction(chosen.motion, *in.predicted, options)) {
    return;
  }
  const std::vector<int> samplable = SamplablePairs(solver, in, options, out);
  const auto inliers_of = [&](const Motion& motion) {
    std::vector<double> errors;
    solver.ErrorsPx(motion, samplable, &errors);
    std::vector<int> inliers;
    for (size_t i = 0; i < samplable.size(); ++i) {
      if (errors[i] <= options.inlier_threshold_px) inliers.push_back(samplable[i]);
    }
    return inliers;
  };
  std::vector<int> inliers = inliers_of(*in.predicted);
  if (inliers.size() < options.prior_inlier_fraction * chosen.inliers.size()) return;
  // Polished locally from the prediction (a fit from scratch would slide back to the far motion);
  // a polish that wanders off leaves the prediction itself.
  Motion motion = PolishOnSampson(*in.predicted, out.correspondences, inliers);
  if (FarFromPrediction(motion, *in.predicted, options)) motion = *in.predicted;
  chosen.motion = motion;
  chosen.inliers = inliers_of(motion);
}

// eq 17 on every pair, then the set the final pose uses.
void ClassifyPairs(const TrackingInputs& in, const VisualOdometryOptions& options,
                   TrackingOutcome& out) {
  StaticTestOptions test;
  test.distance_px = options.static_distance_px;
  // floor: the paper's delta / 2 exactly at the default 0.5.
  test.max_hamming = static_cast<int>(std::floor(options.static_hamming_fraction * options.delta));
  test.focal_px = in.focal_px;
  out.is_static = StaticTest(out.correspondences, out.motion, test);
  out.tested.assign(out.matches.size(), true);
  out.tracking_set.clear();
  for (size_t k = 0; k < out.matches.size(); ++k) {
    const bool in_box = !OutsideBoxes(in, out.matches[k]);
    if (options.filter == DynamicFilter::kBoxesOnly && in_box) out.tested[k] = false;
    if (out.tested[k] && out.is_static[k] && Trackable(options, in_box)) {
      out.tracking_set.push_back(static_cast<int>(k));
    }
  }
}

}  // namespace

TrackingOutcome TrackWithDepth(const TrackingInputs& in, const VisualOdometryOptions& options) {
  TrackingOutcome out;
  MatchFrames(in, options, /*with_points=*/true, out);
  PnpSolver solver(out.correspondences, in.focal_px);
  std::optional<Hypothesis> chosen = SampleMotion(solver, in, options, out);
  if (!chosen) return out;

  const Clock::time_point start = Clock::now();
  absl::StatusOr<Motion> refined =
      RefinePnp(out.correspondences, chosen->inliers, chosen->motion, in.focal_px);
  out.motion = refined.ok() ? *refined : chosen->motion;
  out.inliers = static_cast<int>(chosen->inliers.size());
  ClassifyPairs(in, options, out);
  // The final pose uses every static pair with a 3-D point (in boxes too, for the full method).
  std::vector<int> with_points;
  for (int k : out.tracking_set) {
    if (out.correspondences[k].reference_point) with_points.push_back(k);
  }
  out.tracking_set = with_points;
  if (static_cast<int>(out.tracking_set.size()) < options.min_tracked) {
    out.failure = absl::StrCat("only ", out.tracking_set.size(), " static pairs with depth (need ",
                               options.min_tracked, ")");
    out.pose_ms = MsSince(start);
    return out;
  }
  absl::StatusOr<Motion> final_motion =
      RefinePnp(out.correspondences, out.tracking_set, out.motion, in.focal_px);
  if (final_motion.ok()) out.motion = *final_motion;
  out.pose_ms = MsSince(start);
  out.ok = true;
  return out;
}

TrackingOutcome TrackMonocular(const TrackingInputs& in, const VisualOdometryOptions& options) {
  TrackingOutcome out;
  MatchFrames(in, options, /*with_points=*/false, out);
  EssentialSolver solver(out.correspondences, in.focal_px);
  std::optional<Hypothesis> chosen = SampleMotion(solver, in, options, out);
  if (!chosen) return out;
  // Which of E's decompositions (the sign of t, the twisted pair) is decided by every inlier, not
  // the sample's five: with far points, five can put the camera going backwards, and the motion
  // model would carry that on.
  if (const std::optional<Decomposition> d =
          DecomposeEssential(EssentialOf(chosen->motion), out.correspondences, chosen->inliers)) {
    chosen->motion = d->motion;
  }
  ApplyMotionPrior(solver, in, options, out, *chosen);

  const Clock::time_point start = Clock::now();
  // The sampler already polished its hypotheses on their inliers; a least-squares refit over
  // more pairs is kept only when it explains them better (truncated squared Sampson error): on
  // KITTI 06 the plain refit sometimes slid from the right motion to a sideways one with a few
  // degrees of rotation, which far points with no parallax support almost as well.
  out.motion = chosen->motion;
  out.inliers = static_cast<int>(chosen->inliers.size());
  ClassifyPairs(in, options, out);
  if (static_cast<int>(out.tracking_set.size()) < options.min_tracked) {
    out.failure = absl::StrCat("only ", out.tracking_set.size(), " static pairs (need ",
                               options.min_tracked, ")");
    out.pose_ms = MsSince(start);
    return out;
  }
  out.fit_set = chosen->inliers;
  if (options.join_static_boxed && options.filter == DynamicFilter::kProven) {
    // The static pairs the sampler could not use (boxed, not proven) join the chosen motion's
    // polish now: they passed eq 17 against a motion they had no say in.
    std::vector<int> joined = chosen->inliers;
    for (int k : out.tracking_set) {
      if (!Samplable(in, options, out.matches[k])) joined.push_back(k);
    }
    std::sort(joined.begin(), joined.end());
    joined.erase(std::unique(joined.begin(), joined.end()), joined.end());
    if (joined.size() > chosen->inliers.size()) {
      const Motion polished = PolishOnSampson(out.motion, out.correspondences, joined);
      // With the motion prior on, the polish may not take the motion far from the prediction.
      const bool allowed = options.prior_direction_deg <= 0 || !in.predicted ||
                           !FarFromPrediction(polished, *in.predicted, options) ||
                           FarFromPrediction(out.motion, *in.predicted, options);
      if (allowed && polished.R.allFinite() && polished.t.allFinite()) {
        out.motion = polished;
        out.fit_set = std::move(joined);
      }
    }
  }
  std::vector<int> fit_set = out.fit_set;
  fit_set.insert(fit_set.end(), out.tracking_set.begin(), out.tracking_set.end());
  std::sort(fit_set.begin(), fit_set.end());
  fit_set.erase(std::unique(fit_set.begin(), fit_set.end()), fit_set.end());
  const double cap = options.inlier_threshold_px;
  auto cost = [&](const Motion& motion) {
    double sum = 0;
    for (int k : fit_set) sum += std::pow(std::min(solver.ErrorPx(motion, k), cap), 2);
    return sum;
  };
  absl::StatusOr<Motion> refit = EssentialFromInliers(out.correspondences, fit_set);
  // With the motion prior on, a refit may not take the motion far from the prediction.
  const bool refit_allowed = refit.ok() && (options.prior_direction_deg <= 0 || !in.predicted ||
                                            !FarFromPrediction(*refit, *in.predicted, options) ||
                                            FarFromPrediction(out.motion, *in.predicted, options));
  if (refit_allowed && cost(*refit) < cost(out.motion)) {
    out.motion = *refit;
    out.fit_set = std::move(fit_set);
  }
  out.pose_ms = MsSince(start);
  out.ok = true;
  return out;
}

}  // namespace waymark::visual_slam
