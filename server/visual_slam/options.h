#ifndef WAYMARK_SERVER_VISUAL_SLAM_OPTIONS_H_
#define WAYMARK_SERVER_VISUAL_SLAM_OPTIONS_H_

// Parameters of the dynamic-scene visual odometry (METHODS.md section 3). The paper leaves every
// constant unspecified (delta, d, b1, b2, lambda1, lambda2); the defaults below are ours and each
// comment says where the value comes from.

#include <cstdint>

#include "absl/status/status.h"

namespace waymark::visual_slam {

// Which features are kept out of tracking and mapping.
enum class DynamicFilter {
  kNone,       // every feature is used (plain ORB VO: the ORB-SLAM2-like baseline)
  kBoxesOnly,  // every feature inside a box is dropped, static or not
  kFull,       // the paper: boxes split (eq 7), motion from features outside boxes (eq 10-15),
               // static test on all (eq 17), tracking on all static, mapping outside boxes (eq 18)
  kProven,     // beyond the paper: as kFull, but boxed features stay in the reference as
               // candidates, are matched and tested every frame, and once static for
               // proven_static_frames frames in a row shape the motion model and are mapped like
               // features outside boxes (a parked car helps instead of being thrown away)
};

struct OrbOptions {
  int features = 1000;          // per frame (ORB-SLAM2's TUM setting)
  float scale_factor = 1.2f;    // pyramid step (ORB-SLAM2)
  int levels = 8;               // pyramid levels (ORB-SLAM2)
  int fast_threshold = 20;      // FAST threshold (ORB-SLAM2's iniThFAST)
};

struct SamplerOptions {
  // eq 10: raise the inlier probability eta of pairs in the sample that agree with a best
  // hypothesis by b1, of pairs in a best hypothesis' inlier set but not in the sample by b2, and
  // lower it by b1 for sample pairs that no best hypothesis supports.
  double b1 = 0.1;
  double b2 = 0.02;
  // eq 12: diff_k = lambda1 * angle(q_k^-1 q) [rad] + lambda2 * |t_k - t| [m, or unit-norm
  // translations monocular]. 1 rad ~ 1 m: a 6 degree disagreement weighs like 10 cm.
  double lambda1 = 1.0;
  double lambda2 = 1.0;
  // Hypotheses within this fraction of the best inlier count take part in the eq 12 tie-break
  // (a hypothesis with far fewer inliers never wins on motion alone).
  double tie_break_fraction = 0.8;
  // Re-rankings (eq 10-11 loop) before giving up on a stable order, and samples per round in eta
  // order. Measured on the Bonn crowd window (waymark-vo-bench, 5 seeds): 4 x 32 gives the same
  // ATE as 8 x 64 (full method median 0.035 vs 0.034 m) for 3.5 instead of 11.6 ms per frame.
  int max_rounds = 4;
  int hypotheses_per_round = 32;
  // Samples per round are multiplied by this for a frame with no motion prediction (a session's
  // first motion, or after a reset): nothing narrows the choice then, and a wrong first motion
  // misleads every prediction after it (KITTI 06, monocular: 1 of 10 sampler seeds took a
  // sideways first motion with 32 per round). Costs one slower frame per session.
  int unpredicted_factor = 4;
  uint64_t seed = 1;             // deterministic sampling
};

struct VisualOdometryOptions {
  DynamicFilter filter = DynamicFilter::kFull;
  OrbOptions orb;
  SamplerOptions sampler;
  // eq 8: coarse matches need a Hamming distance below delta (of 256 bits). ORB-SLAM2 uses 50 as
  // its strict and 100 as its loose threshold; 64 sits between.
  int delta = 64;
  // Lowe-style ratio between the best and second-best Hamming distance (ORB-SLAM2: 0.7-0.9).
  double match_ratio = 0.8;
  // eq 17: a feature is static when its predicted position is within d pixels of its match and
  // its Hamming distance is below delta / 2.
  double static_distance_px = 3.0;
  // eq 17's descriptor half as a fraction of delta: static needs hamming < this * delta. The
  // paper's 0.5; 1.0 leaves only the geometric half (every coarse match is already < delta).
  double static_hamming_fraction = 0.5;
  // kProven: consecutive frames a boxed feature must pass eq 17 before it counts as mapped.
  int proven_static_frames = 3;
  // Beyond the paper (kProven): a boxed pair that passes eq 17 against the motion sampled without
  // it joins the final fit in the same frame (monocular: the local polish of the chosen motion;
  // RGB-D's final PnP refit already takes every static pair) and the bundle adjustment's window
  // (its reference observation too), instead of only once proven. It is still never sampled, so a
  // moving object cannot choose the motion. Near features on parked cars move fast across a
  // forward-moving camera's image and rarely stay static long enough to be proven (KITTI 06 0-50:
  // 13 boxed pairs static per frame, 5 proven). false = the proven filter as it was.
  bool join_static_boxed = false;
  // Inlier threshold of the motion hypotheses (reprojection or Sampson distance), pixels.
  double inlier_threshold_px = 2.0;
  // Depth: metres = value / depth_scale (TUM and Bonn: 5000). Readings outside
  // [min_depth, max_depth] metres are ignored.
  double depth_scale = 5000;
  double min_depth = 0.1;
  double max_depth = 8.0;
  // Tracking needs this many static matches; fewer = lost (the pose is predicted).
  int min_tracked = 15;
  // A new keyframe when the tracked matches fall below this fraction of the keyframe's points,
  // or the camera moved this far from it (m, RGB-D) or turned this much (rad).
  double keyframe_tracked_fraction = 0.6;
  double keyframe_distance = 0.10;
  double keyframe_angle = 0.17;  // 10 degrees
  // Keyframes kept in the local map; tracking falls back to older ones when the newest fails.
  int local_map_keyframes = 5;
  // Beyond the paper: a monocular motion heading more than prior_direction_deg, or turning more
  // than prior_rotation_deg, away from the constant-velocity prediction is replaced by the
  // prediction polished on the pairs it explains, when those are at least prior_inlier_fraction
  // of the chosen motion's inliers. Far points leave a sideways or backwards motion almost as
  // consistent as the true one (on KITTI 06 a few frames per 50 came out 75-178 degrees off); a
  // vehicle does not turn that way in 0.1 s. 0 = off (the paper).
  double prior_direction_deg = 0;
  double prior_rotation_deg = 5;
  double prior_inlier_fraction = 0.7;
  // Beyond the paper: keyframes that leave the local map are kept, up to this many (monocular:
  // one tracked frame in five, with the depths that carry the session's scale), and a frame the
  // local map cannot track is tried against the few of them its features match best before it is
  // declared lost (the paper: a constant-velocity guess and a new keyframe there). 0 = off.
  int relocalization_keyframes = 0;
  // Beyond the paper: after each new keyframe, a bundle adjustment of the last bundle_window
  // keyframes and the points they share (local_map.h) runs on a background thread; 0 = off (the
  // paper). Monocular sessions make every tracked frame a keyframe, so the window is frames.
  int bundle_window = 0;
  // Apply each adjustment before the next frame, waiting for it if needed: deterministic answers
  // (tests, benchmarks) at the cost of the next frame's latency. Off: applied once finished.
  bool bundle_wait = false;
  // The bundle adjustment runs on monocular sessions only: an RGB-D session (its first frame has
  // depth) takes bundle_window 0. The measured best sets it (no gain on Bonn RGB-D, see
  // docs/visual-odometry.md).
  bool bundle_monocular_only = false;

  absl::Status Validate() const;

  // The two presets (issue 35). A default-constructed VisualOdometryOptions is the paper's
  // pipeline (every constant above), and Paper() returns exactly that. MeasuredBest() is the
  // service's and `vo run`'s default: the best configuration measured per input kind
  // (docs/visual-odometry.md, "Defaults"): the proven-static filter with eq 17's descriptor half
  // off, boxed features proven after 2 frames, boxed pairs static against the sampled motion
  // joining the final fit and the bundle window at once (join_static_boxed); monocular also the
  // motion prior (30 degrees) and a 10-frame local bundle adjustment (RGB-D: none,
  // bundle_monocular_only).
  static VisualOdometryOptions Paper() { return VisualOdometryOptions(); }
  static VisualOdometryOptions MeasuredBest();
};

enum class Preset {
  kMeasuredBest,  // the default (VisualOdometryOptions::MeasuredBest)
  kPaper,         // the paper's pipeline exactly (VisualOdometryOptions::Paper)
};
VisualOdometryOptions OptionsForPreset(Preset preset);
const char* PresetName(Preset preset);

}  // namespace waymark::visual_slam

#endif  // WAYMARK_SERVER_VISUAL_SLAM_OPTIONS_H_
