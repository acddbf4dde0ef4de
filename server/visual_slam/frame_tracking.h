#ifndef WAYMARK_SERVER_VISUAL_SLAM_FRAME_TRACKING_H_
#define WAYMARK_SERVER_VISUAL_SLAM_FRAME_TRACKING_H_

// Tracks the current frame against one reference (a keyframe, RGB-D; the previous frame,
// monocular): coarse matching (eq 8), the motion model by sequential sampling over the pairs
// outside boxes (eq 10-12), the pose (PnP + refinement on the reference's 3-D points, or the
// essential matrix, eq 14-15), the static test on every pair (eq 17) and the final pose from every
// static pair the filter allows.

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "server/visual_slam/coarse_matching.h"
#include "server/visual_slam/frame_features.h"
#include "server/visual_slam/geometry/correspondence.h"
#include "server/visual_slam/options.h"
#include "server/visual_slam/types.h"

namespace waymark::visual_slam {

struct TrackingOutcome {
  bool ok = false;
  std::string failure;  // why not ok (for logs and tests)
  Motion motion;        // reference -> current; unit translation when monocular
  std::vector<DescriptorMatch> matches;
  std::vector<Correspondence> correspondences;  // one per match
  std::vector<bool> tested;                     // per match: the static test ran on it
  std::vector<bool> is_static;    // per match: passed eq 17 (only meaningful when tested)
  std::vector<int> tracking_set;  // matches the final pose was computed from
  // Monocular: the pairs the chosen motion was last polished on (the sampler's inliers, plus the
  // static boxed pairs with join_static_boxed); the refit from scratch over the chosen inliers and
  // the tracking set replaces it only when it explains them better.
  std::vector<int> fit_set;
  int hypotheses = 0;
  int inliers = 0;  // of the chosen motion hypothesis (after the motion prior)
  double matching_ms = 0, sampling_ms = 0, pose_ms = 0;
};

// What a reference feature may do (the kProven filter; every feature is kMapped otherwise).
enum class ReferenceRole : uint8_t {
  kMapped,     // outside every box when it was found: shapes the motion model (eq 9, 18)
  kCandidate,  // found inside a box: matched and tested, tracked when static, never sampled
  kProven,     // a candidate static for proven_static_frames frames in a row: like kMapped,
               // also where it is inside a box now
};

struct TrackingInputs {
  const FrameFeatures* reference = nullptr;
  const FrameFeatures* current = nullptr;
  const std::vector<bool>* current_in_box = nullptr;            // eq 7, per current feature
  const std::vector<ReferenceRole>* reference_roles = nullptr;  // null = every one kMapped
  // The coarse matches of current to reference when already computed (the pipeline matches the
  // newest keyframe while the detector runs); null = match here.
  const std::vector<DescriptorMatch>* matches = nullptr;
  std::optional<Motion> predicted;  // reference -> current, from the previous motion
  double focal_px = 500;
};

// RGB-D: the reference's features must carry depth; the motion is metric.
TrackingOutcome TrackWithDepth(const TrackingInputs& in, const VisualOdometryOptions& options);

// Monocular: the motion's translation has unit length (scale is the caller's business).
TrackingOutcome TrackMonocular(const TrackingInputs& in, const VisualOdometryOptions& options);

}  // namespace waymark::visual_slam

#endif  // WAYMARK_SERVER_VISUAL_SLAM_FRAME_TRACKING_H_
