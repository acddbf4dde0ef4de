#include "server/visual_slam/visual_odometry.h"

// Over 700 lines on purpose (issue 36): the session's pipeline, its relocalisation and its
// checkpoint all work on State, Reference and Anchor, which are private to this file so that no
// other code can lean on the pipeline's internals. Splitting it means an internal header for them;
// the first change that needs State elsewhere should do that.

#include <algorithm>
#include <cmath>
#include <deque>
#include <future>
#include <opencv2/imgproc.hpp>
#include <utility>

#include "absl/strings/str_cat.h"
#include "server/common/binary_io.h"
#include "server/common/stopwatch.h"
#include "server/visual_slam/camera_check.h"
#include "server/visual_slam/frame_features.h"
#include "server/visual_slam/frame_tracking.h"
#include "server/visual_slam/frame_validation.h"
#include "server/visual_slam/geometry/box_split.h"
#include "server/visual_slam/geometry/pose_algebra.h"
#include "server/visual_slam/geometry/two_view.h"
#include "server/visual_slam/mapping/local_map.h"
#include "server/visual_slam/pose_io.h"

namespace waymark::visual_slam {

// A reference the current frame is tracked against. RGB-D: a keyframe holding only its map points
// (static features outside boxes with depth, eq 18). Monocular: the last tracked frame, with the
// depth of its features triangulated at the session's scale (for the next frame's scale).
struct Reference {
  int64_t id = 0;  // keyframe id (the local map's)
  double stamp = 0;
  Pose pose;
  FrameFeatures features;
  // Per feature (kProven; all kMapped otherwise): its role, and for boxed ones the frames in a
  // row it has passed the static test.
  std::vector<ReferenceRole> roles;
  std::vector<int> static_run;
  // Per feature: its track in the local map (bundle adjustment on; empty otherwise).
  std::vector<int64_t> tracks;
  // Static pairs of the first frame tracked against this keyframe: the yardstick of the
  // "tracking got weak" keyframe rule (most map points are never matched at all, so the map size
  // is not).
  int first_tracked = 0;
};

// A frame's pose as its keyframe's pose and the motion from there: when an adjustment moves the
// keyframe, the frame moves with it.
struct Anchor {
  int64_t keyframe = -1;
  Motion motion;  // keyframe -> frame
};

struct BundleOutcome {
  BundleJob job;
  absl::StatusOr<BundleResult> result;
  double ms = 0;
};

// Monocular sessions archive one reference (tracked frame) in this many for relocalisation.
constexpr int64_t kMonoArchiveSpacing = 5;

struct VisualOdometry::State {
  explicit State(const VisualOdometryOptions& options, const CameraModel& camera)
      : extractor(options.orb, camera) {}
  OrbExtractor extractor;
  int64_t next_keyframe_id = 0;
  // Bundle adjustment (options.bundle_window > 0): the window (which holds the poses an
  // adjustment may still move), the job running in the background, and every frame's anchor.
  std::optional<LocalMap> local_map;
  std::future<BundleOutcome> bundle;
  std::vector<Anchor> anchors;     // parallel to the trajectory
  std::optional<bool> with_depth;  // fixed by the first frame
  std::optional<double> last_stamp;
  std::deque<Reference> keyframes;  // newest first (RGB-D local map); monocular: one entry
  std::deque<Reference> archive;    // keyframes gone from the local map, newest first
  std::optional<Pose> last_pose;
  std::optional<Pose> previous_pose;  // the frame before last_pose (constant-velocity model)
  double mono_speed = 1.0;            // monocular: length of the last frame-to-frame translation
};

namespace {

double Percentile50(std::vector<double> values) {
  if (values.empty()) return 0;
  std::nth_element(values.begin(), values.begin() + values.size() / 2, values.end());
  return values[values.size() / 2];
}

// The subset of `features` selected by `keep`.
FrameFeatures Subset(const FrameFeatures& features, const std::vector<bool>& keep) {
  FrameFeatures out;
  for (int i = 0; i < features.size(); ++i) {
    if (!keep[i]) continue;
    out.pixels.push_back(features.pixels[i]);
    out.normalized.push_back(features.normalized[i]);
    out.depth.push_back(features.depth[i]);
    out.descriptors.push_back(features.descriptors.row(i));
  }
  return out;
}

// What tracking the current frame against `reference` needs (no prediction, matching to do).
TrackingInputs InputsFor(const Reference& reference, const FrameFeatures& features,
                         const std::vector<bool>& in_box, double focal_px) {
  TrackingInputs in;
  in.reference = &reference.features;
  in.current = &features;
  in.current_in_box = &in_box;
  if (!reference.roles.empty()) in.reference_roles = &reference.roles;
  in.focal_px = focal_px;
  return in;
}

// Adds an attempt's stage times to the frame's.
void AddTimes(const TrackingOutcome& attempt, StageTimings* timings) {
  timings->matching_ms += attempt.matching_ms;
  timings->sampling_ms += attempt.sampling_ms;
  timings->pose_ms += attempt.pose_ms;
}

template <typename T>
std::vector<T> Subset(const std::vector<T>& values, const std::vector<bool>& keep) {
  std::vector<T> out;
  for (size_t i = 0; i < values.size(); ++i) {
    if (keep[i]) out.push_back(values[i]);
  }
  return out;
}


// The median angle (degrees) between the rays of the tracked pairs once the motion's rotation is
// taken out: the parallax the translation has to be seen from (monocular: almost none = a pure
// rotation, or no motion, and the essential matrix's translation is noise).
double MedianParallaxDeg(const TrackingOutcome& outcome) {
  std::vector<double> angles;
  angles.reserve(outcome.tracking_set.size());
  for (int k : outcome.tracking_set) {
    const Correspondence& c = outcome.correspondences[k];
    const Eigen::Vector3d a = outcome.motion.R * c.reference.homogeneous().normalized();
    const Eigen::Vector3d b = c.current.homogeneous().normalized();
    angles.push_back(std::atan2(a.cross(b).norm(), a.dot(b)) * 180 / M_PI);
  }
  return angles.empty() ? 0 : Percentile50(angles);
}

}  // namespace

TrackingQuality VisualOdometry::Quality(const FrameResult& result, const TrackingOutcome& outcome,
                                        bool tracked, bool rgbd) const {
  TrackingQuality q;
  q.inliers = outcome.inliers;
  if (result.state == TrackingState::kInitializing) return q;
  if (result.state == TrackingState::kLost || !tracked) {
    q.level = TrackingQuality::Level::kLost;
    q.reason = outcome.failure.empty() ? "lost: the pose is predicted" : outcome.failure;
    return q;
  }
  q.parallax_deg = MedianParallaxDeg(outcome);
  q.level = TrackingQuality::Level::kGood;
  if (q.inliers < kWeakInlierFactor * options_.min_tracked) {
    q.level = TrackingQuality::Level::kWeak;
    q.reason = absl::StrCat("few inliers (", q.inliers, ")");
  } else if (!rgbd && q.parallax_deg < kLowParallaxDeg) {
    q.level = TrackingQuality::Level::kWeak;
    q.reason = absl::StrCat("no parallax (median ", absl::SixDigits(q.parallax_deg),
                            " degrees): a rotation or no motion, the translation is a guess");
  }
  return q;
}

VisualOdometry::VisualOdometry(const VisualOdometryOptions& options, const CameraModel& camera,
                               std::unique_ptr<ObjectDetector> detector)
    : options_(options),
      camera_(camera),
      detector_(std::move(detector)),
      state_(std::make_unique<State>(options, camera)) {}

VisualOdometry::~VisualOdometry() = default;

absl::StatusOr<std::unique_ptr<VisualOdometry>> VisualOdometry::Create(
    const VisualOdometryOptions& options, const CameraModel& camera,
    std::unique_ptr<ObjectDetector> detector) {
  if (absl::Status status = options.Validate(); !status.ok()) return status;
  if (absl::Status status = ValidateCamera(camera); !status.ok()) return status;
  return std::unique_ptr<VisualOdometry>(new VisualOdometry(options, camera, std::move(detector)));
}

void VisualOdometry::ResetAt(const TimedPose& pose) {
  State& s = *state_;
  if (s.bundle.valid()) s.bundle.wait();  // its keyframes are gone: its answer is dropped
  s.bundle = {};
  s.local_map.reset();
  s.anchors.clear();  // made again at the next keyframe
  s.keyframes.clear();
  s.last_pose = pose.pose;
  s.previous_pose.reset();
  s.last_stamp = pose.stamp;
}

absl::StatusOr<FrameResult> VisualOdometry::ProcessFrame(const FrameInput& frame) {
  State& s = *state_;
  const Clock::time_point start = Clock::now();
  if (absl::Status status = ValidateFrame(frame, camera_, s.last_stamp, s.with_depth);
      !status.ok()) {
    return status;
  }
  FrameResult result;
  result.stamp = frame.stamp;
  ApplyBundle(options_.bundle_wait, &result.timings);

  // The detector runs on its own thread while this one extracts ORB features and matches them
  // to the newest keyframe: the two are independent until the box split, and on a 2-core robot
  // server the detector is the longest stage. A detector failure leaves the session unchanged
  // (nothing below changes state before the boxes are in).
  std::future<absl::StatusOr<std::vector<Box>>> detection;
  Clock::time_point detector_start = Clock::now();
  if (!frame.boxes && detector_ != nullptr) {
    detection =
        std::async(std::launch::async, [this, &frame] { return detector_->Detect(frame.image); });
  }

  Clock::time_point stage = Clock::now();
  cv::Mat gray = frame.image;
  if (gray.channels() == 3) cv::cvtColor(frame.image, gray, cv::COLOR_BGR2GRAY);
  FrameFeatures features = s.extractor.Extract(gray, frame.depth, options_.depth_scale,
                                               options_.min_depth, options_.max_depth);
  result.timings.orb_ms = MsSince(stage);
  stage = Clock::now();
  std::vector<DescriptorMatch> newest_matches;
  if (!s.keyframes.empty()) {
    newest_matches = CoarseMatch(features.descriptors, s.keyframes.front().features.descriptors,
                                 options_.delta, options_.match_ratio);
  }
  const double newest_matching_ms = MsSince(stage);

  if (frame.boxes) {
    result.boxes = *frame.boxes;
  } else if (detection.valid()) {
    absl::StatusOr<std::vector<Box>> boxes = detection.get();
    result.timings.detector_ms = MsSince(detector_start);
    if (!boxes.ok()) {
      return absl::Status(boxes.status().code(), absl::StrCat("detector ", detector_->name(), ": ",
                                                              boxes.status().message()));
    }
    result.boxes = *std::move(boxes);
  }

  const std::vector<bool> in_box = InsideAnyBox(features.pixels, result.boxes);
  const bool use_boxes = options_.filter != DynamicFilter::kNone;
  result.keypoints = features.pixels;
  result.labels.assign(features.size(), FeatureLabel::kUnmatched);
  result.counts.total = features.size();
  for (int i = 0; i < features.size(); ++i) {
    if (in_box[i]) {
      ++result.counts.potentially_dynamic;
      if (use_boxes) result.labels[i] = FeatureLabel::kPotentiallyDynamic;
    }
  }

  if (!s.with_depth) {
    s.with_depth = !frame.depth.empty();
    // The input kind is known now: the preset's per-kind choices take effect.
    if (*s.with_depth && options_.bundle_monocular_only) options_.bundle_window = 0;
    if (trajectory_.empty()) result.warnings = CameraWarnings(camera_);
  }
  const bool rgbd = *s.with_depth;
  const double focal = 0.5 * (camera_.fx + camera_.fy);

  // Constant-velocity prediction of this frame's pose.
  std::optional<Pose> predicted_pose;
  if (s.last_pose && s.previous_pose) {
    predicted_pose = PoseAfter(*s.last_pose, MotionBetween(*s.previous_pose, *s.last_pose));
  } else if (s.last_pose) {
    predicted_pose = s.last_pose;
  }

  // Track against the local map, newest reference first.
  TrackingOutcome outcome;
  Reference* reference = nullptr;
  for (Reference& candidate : s.keyframes) {
    TrackingInputs in = InputsFor(candidate, features, in_box, focal);
    if (&candidate == &s.keyframes.front()) {
      in.matches = &newest_matches;
      result.timings.matching_ms += newest_matching_ms;
    }
    if (predicted_pose) {
      Motion predicted = MotionBetween(candidate.pose, *predicted_pose);
      if (!rgbd && predicted.t.norm() > 1e-9) predicted.t.normalize();
      in.predicted = predicted;
    }
    TrackingOutcome attempt = rgbd ? TrackWithDepth(in, options_) : TrackMonocular(in, options_);
    AddTimes(attempt, &result.timings);
    const bool ok = attempt.ok;
    outcome = std::move(attempt);
    if (ok) {
      reference = &candidate;
      break;
    }
    if (!rgbd) break;  // monocular keeps one reference
  }
  if (reference == nullptr && !s.archive.empty() && features.size() >= options_.min_tracked) {
    reference = Relocalize(features, in_box, focal, rgbd, &outcome, &result.timings);
    result.relocalized = reference != nullptr;
  }

  // Label the current features from the pairs.
  std::vector<bool> dynamic(features.size(), false);
  for (size_t k = 0; k < outcome.matches.size(); ++k) {
    const int q = outcome.matches[k].query;
    if (k < outcome.tested.size() && outcome.tested[k]) {
      if (!outcome.is_static[k]) {
        result.labels[q] = FeatureLabel::kDynamic;
        dynamic[q] = true;
        ++result.counts.dynamic;
      } else {
        result.labels[q] =
            (in_box[q] && use_boxes) ? FeatureLabel::kStaticInBox : FeatureLabel::kStatic;
      }
    }
  }
  result.counts.matched = static_cast<int>(outcome.matches.size());

  // Bundle adjustment: a feature tracked from the reference continues the reference feature's
  // track (the same scene point, seen again).
  std::vector<int64_t> tracks(features.size(), -1);
  if (reference != nullptr && !reference->tracks.empty()) {
    for (int k : outcome.tracking_set) {
      tracks[outcome.matches[k].query] = reference->tracks[outcome.matches[k].train];
    }
  }
  // join_static_boxed: a static pair whose reference feature is still a candidate joins the
  // adjustment's window now, both its observations (the reference's was kept out when added).
  const bool joining = options_.join_static_boxed && options_.filter == DynamicFilter::kProven;
  std::vector<bool> joined(features.size(), false);
  if (joining && reference != nullptr && !reference->roles.empty()) {
    for (int k : outcome.tracking_set) {
      const int t = outcome.matches[k].train;
      if (reference->roles[t] != ReferenceRole::kCandidate) continue;
      joined[outcome.matches[k].query] = true;
      if (s.local_map && !reference->tracks.empty()) {
        s.local_map->Admit(reference->id, t, reference->tracks[t]);
      }
    }
  }

  // kProven: the frames in a row each boxed feature has been static. The reference's own count
  // moves too (an RGB-D keyframe is tested by every frame tracked against it, and promotes its
  // candidates in place); the current feature inherits it for when it joins the next reference.
  const bool proving = options_.filter == DynamicFilter::kProven;
  std::vector<int> static_run(features.size(), 0);
  if (proving && reference != nullptr && !reference->roles.empty()) {
    for (size_t k = 0; k < outcome.matches.size(); ++k) {
      if (k >= outcome.tested.size() || !outcome.tested[k]) continue;
      const int q = outcome.matches[k].query;
      const int t = outcome.matches[k].train;
      const int run = outcome.is_static[k] ? reference->static_run[t] + 1 : 0;
      reference->static_run[t] = run;
      if (run >= options_.proven_static_frames &&
          reference->roles[t] == ReferenceRole::kCandidate) {
        reference->roles[t] = ReferenceRole::kProven;
      }
      static_run[q] = run;
    }
  }

  stage = Clock::now();
  Pose pose = predicted_pose.value_or(Pose{});
  std::vector<std::optional<double>> mono_depth(features.size());
  bool make_keyframe = false;
  if (s.keyframes.empty()) {
    result.state = TrackingState::kInitializing;
    make_keyframe = true;
  } else if (reference == nullptr) {
    result.state = TrackingState::kLost;
    // RGB-D: start a new local map here at the predicted pose so the next frames can track again.
    make_keyframe = true;
  } else {
    result.state = TrackingState::kTracking;
    result.counts.tracked = static_cast<int>(outcome.tracking_set.size());
    Motion motion = outcome.motion;
    if (!rgbd) {
      // Scale of the unit translation: the reference's features carry depths at the session's
      // scale; the same pairs triangulated with the unit motion give their depths at scale 1.
      std::vector<double> ratios;
      std::vector<std::optional<Eigen::Vector3d>> points(outcome.matches.size());
      for (int k : outcome.tracking_set) {
        const Correspondence& c = outcome.correspondences[k];
        points[k] = Triangulate(motion, c.reference, c.current);
        const std::optional<double>& known = reference->features.depth[outcome.matches[k].train];
        if (points[k] && known) ratios.push_back(*known / points[k]->z());
      }
      const double scale = ratios.size() >= 8 ? Percentile50(ratios) : s.mono_speed;
      if (std::isfinite(scale) && scale > 0) {
        motion.t *= scale;
        s.mono_speed = scale;
      }
      for (int k : outcome.tracking_set) {
        if (!points[k]) continue;
        const Eigen::Vector3d in_current = motion.R * (*points[k] * s.mono_speed) + motion.t;
        if (in_current.z() > 0) mono_depth[outcome.matches[k].query] = in_current.z();
      }
    }
    pose = PoseAfter(reference->pose, motion);
    if (reference->first_tracked == 0) reference->first_tracked = result.counts.tracked;
    if (rgbd) {
      const Motion from_keyframe = MotionBetween(s.keyframes.front().pose, pose);
      const bool weak =
          result.counts.tracked < options_.keyframe_tracked_fraction * reference->first_tracked;
      make_keyframe = reference != &s.keyframes.front() || weak ||
                      from_keyframe.t.norm() > options_.keyframe_distance ||
                      RotationAngle(from_keyframe.R) > options_.keyframe_angle;
    } else {
      make_keyframe = true;  // monocular tracks frame to frame
    }
  }
  if (!IsFinite(pose)) {
    // No non-finite pose leaves the engine (a degenerate solve): the frame counts as lost, at the
    // constant-velocity guess, and starts a keyframe there as any lost frame does.
    result.state = TrackingState::kLost;
    result.counts.tracked = 0;
    pose = predicted_pose && IsFinite(*predicted_pose) ? *predicted_pose
                                                       : s.last_pose.value_or(Pose{});
    mono_depth.assign(features.size(), std::nullopt);
    reference = nullptr;
    make_keyframe = true;
  }
  result.quality = Quality(result, outcome, reference != nullptr, rgbd);
  if (make_keyframe) {
    // eq 18: the map takes static features outside boxes (with depth, RGB-D). kProven also keeps
    // the boxed ones not found dynamic: as candidates, or as mapped once proven static.
    std::vector<bool> keep(features.size(), false);
    std::vector<ReferenceRole> roles(features.size(), ReferenceRole::kMapped);
    for (int i = 0; i < features.size(); ++i) {
      if (dynamic[i]) continue;
      if (use_boxes && in_box[i]) {
        if (!proving) continue;
        roles[i] = static_run[i] >= options_.proven_static_frames ? ReferenceRole::kProven
                                                                  : ReferenceRole::kCandidate;
      }
      if (rgbd ? features.depth[i].has_value() : true) keep[i] = true;
    }
    Reference keyframe;
    keyframe.id = s.next_keyframe_id++;
    keyframe.stamp = frame.stamp;
    keyframe.pose = pose;
    if (!rgbd) features.depth = mono_depth;
    keyframe.features = Subset(features, keep);
    if (options_.bundle_window > 0) {
      if (!s.local_map) {
        s.local_map.emplace(NewLocalMap(/*monocular=*/!rgbd));
      }
      std::vector<bool> in_map(features.size());
      for (int i = 0; i < features.size(); ++i) {
        in_map[i] = roles[i] != ReferenceRole::kCandidate || joined[i];
      }
      keyframe.tracks = s.local_map->AddKeyframe(keyframe.id, pose, keyframe.features,
                                                 Subset(tracks, keep), Subset(in_map, keep));
    }
    if (proving) {
      keyframe.roles = Subset(roles, keep);
      keyframe.static_run = Subset(static_run, keep);
    }
    result.counts.mapped = 0;
    for (int i = 0; i < features.size(); ++i) {
      if (!keep[i]) continue;
      if (roles[i] == ReferenceRole::kProven) ++result.counts.proven;
      if (roles[i] != ReferenceRole::kCandidate) ++result.counts.mapped;
    }
    result.keyframe = true;
    s.keyframes.push_front(std::move(keyframe));
    const size_t keep_count = rgbd ? static_cast<size_t>(options_.local_map_keyframes) : 1;
    while (s.keyframes.size() > keep_count) {
      // Kept for relocalisation when asked for and it has enough to track against. Monocular
      // references are every tracked frame: one in kMonoArchiveSpacing is kept, so that the
      // archive spans a longer stretch of the path.
      const Reference& leaving = s.keyframes.back();
      const bool spaced =
          rgbd || s.archive.empty() || leaving.id >= s.archive.front().id + kMonoArchiveSpacing;
      if (options_.relocalization_keyframes > 0 && spaced &&
          leaving.features.size() >= options_.min_tracked) {
        s.archive.push_front(std::move(s.keyframes.back()));
        while (static_cast<int>(s.archive.size()) > options_.relocalization_keyframes) {
          s.archive.pop_back();
        }
      }
      s.keyframes.pop_back();
    }
    if (options_.bundle_window > 0) StartBundle();
  }
  result.timings.mapping_ms = MsSince(stage);

  result.pose = pose;
  // The velocity across a loss is unknown: after a relocalised frame the next is predicted to
  // stand still (and sampled as a first motion).
  s.previous_pose = result.relocalized ? std::nullopt : s.last_pose;
  s.last_pose = pose;
  s.last_stamp = frame.stamp;
  trajectory_.push_back({frame.stamp, pose});
  if (options_.bundle_window > 0) {
    Anchor anchor;
    if (result.keyframe) {
      anchor.keyframe = s.keyframes.front().id;
    } else if (reference != nullptr) {  // no keyframe made: still in the local map
      anchor.keyframe = reference->id;
      anchor.motion = MotionBetween(reference->pose, pose);
    }
    s.anchors.push_back(anchor);
  }
  result.timings.total_ms = MsSince(start);
  return result;
}

LocalMap VisualOdometry::NewLocalMap(bool monocular) const {
  LocalMapOptions map_options;
  map_options.window = options_.bundle_window;
  map_options.bundle.focal_px = 0.5 * (camera_.fx + camera_.fy);
  return LocalMap(map_options, monocular);
}

void VisualOdometry::StartBundle() {
  State& s = *state_;
  if (!s.local_map || s.bundle.valid()) return;  // one adjustment at a time
  std::optional<BundleJob> job = s.local_map->MakeJob();
  if (!job) return;
  s.bundle = std::async(std::launch::async,
                        [job = *std::move(job), bundle = s.local_map->bundle_options()]() mutable {
                          const Clock::time_point start = Clock::now();
                          BundleOutcome outcome;
                          outcome.result = BundleAdjust(job.problem, bundle);
                          outcome.job = std::move(job);
                          outcome.ms = MsSince(start);
                          return outcome;
                        });
}

void VisualOdometry::ApplyBundle(bool wait, StageTimings* timings) {
  State& s = *state_;
  if (!s.bundle.valid()) return;
  const Clock::time_point start = Clock::now();
  if (!wait && s.bundle.wait_for(std::chrono::seconds(0)) != std::future_status::ready) return;
  BundleOutcome outcome = s.bundle.get();
  timings->bundle_wait_ms = MsSince(start);
  timings->bundle_ms = outcome.ms;
  if (!outcome.result.ok() || !s.local_map) return;  // a bad window is skipped, not fatal
  s.local_map->Apply(outcome.job, *outcome.result);
  // Keyframes older than the job never move again: the next adjustment holds them or has
  // dropped them.
  const int64_t oldest = outcome.job.keyframe_ids.front();
  const bool monocular = s.with_depth && !*s.with_depth;
  for (Reference& reference : s.keyframes) {
    std::optional<Pose> adjusted = s.local_map->PoseOf(reference.id);
    if (!adjusted) continue;
    reference.pose = *adjusted;
    if (!monocular || reference.tracks.empty()) continue;
    // Monocular scale comes from the reference's depths: take them from the adjusted points.
    for (int i = 0; i < reference.features.size(); ++i) {
      std::optional<Eigen::Vector3d> point = s.local_map->Point(reference.tracks[i]);
      if (!point) continue;
      const double z = (reference.pose.R.transpose() * (*point - reference.pose.t)).z();
      if (z > 0) reference.features.depth[i] = z;
    }
  }
  // Every frame anchored to a keyframe that moved follows it. The anchors are those of the last
  // frames (none before a reset or a restore).
  const size_t first_anchored = trajectory_.size() - std::min(trajectory_.size(), s.anchors.size());
  for (size_t i = trajectory_.size(); i-- > first_anchored;) {
    const Anchor& anchor = s.anchors[i - first_anchored];
    if (anchor.keyframe < oldest) break;
    if (std::optional<Pose> keyframe = s.local_map->PoseOf(anchor.keyframe)) {
      trajectory_[i].pose = PoseAfter(*keyframe, anchor.motion);
    }
  }
  if (!trajectory_.empty() && s.last_pose) s.last_pose = trajectory_.back().pose;
  if (trajectory_.size() >= 2 && s.previous_pose) {
    s.previous_pose = trajectory_[trajectory_.size() - 2].pose;
    if (monocular) s.mono_speed = (s.last_pose->t - s.previous_pose->t).norm();
  }
}

Reference* VisualOdometry::Relocalize(const FrameFeatures& features,
                                      const std::vector<bool>& in_box, double focal_px, bool rgbd,
                                      TrackingOutcome* outcome, StageTimings* timings) {
  State& s = *state_;
  const Clock::time_point start = Clock::now();
  // A cheap vote first: a sample of this frame's descriptors against each archived keyframe.
  // Only the best few are tracked in full, so a long loss costs a bounded time per frame.
  constexpr int kSample = 150;
  constexpr int kCandidates = 3;
  const int step = std::max(1, features.size() / kSample);
  cv::Mat sample;
  for (int i = 0; i < features.size(); i += step) sample.push_back(features.descriptors.row(i));
  std::vector<std::pair<int, Reference*>> votes;
  for (Reference& candidate : s.archive) {
    const int matches = static_cast<int>(
        CoarseMatch(sample, candidate.features.descriptors, options_.delta, options_.match_ratio)
            .size());
    if (matches >= options_.min_tracked / 2) votes.push_back({matches, &candidate});
  }
  std::stable_sort(votes.begin(), votes.end(),
                   [](const auto& a, const auto& b) { return a.first > b.first; });
  if (votes.size() > kCandidates) votes.resize(kCandidates);
  timings->matching_ms += MsSince(start);
  for (const auto& [count, candidate] : votes) {
    // No prediction: the guess is what failed.
    // Monocular: the archived frame's depths (at the session's scale) give the scale.
    const TrackingInputs in = InputsFor(*candidate, features, in_box, focal_px);
    TrackingOutcome attempt = rgbd ? TrackWithDepth(in, options_) : TrackMonocular(in, options_);
    AddTimes(attempt, timings);
    if (attempt.ok) {
      *outcome = std::move(attempt);
      return candidate;
    }
  }
  return nullptr;
}

namespace {

constexpr uint32_t kStateMagic = 0x4f56574d;  // "MWVO"
// v1: keyframes and archive. v2 adds each keyframe's tracks and the bundle adjustment's window
// with its points.
constexpr uint32_t kStateVersion = 2;
constexpr uint32_t kMaxStoredFeatures = 100000;
constexpr uint32_t kMaxStoredKeyframes = 10000;

void PutOptionalPose(BinaryWriter& out, const std::optional<Pose>& pose) {
  out.Put<uint8_t>(pose.has_value());
  if (pose) PutPose(out, *pose);
}

bool GetOptionalPose(BinaryReader& in, std::optional<Pose>* pose) {
  uint8_t has = 0;
  if (!in.Get(&has)) return false;
  if (!has) return true;
  Pose p;
  if (!GetPose(in, &p)) return false;
  *pose = p;
  return true;
}

void PutReference(BinaryWriter& out, const Reference& r) {
  out.Put<int64_t>(r.id);
  out.Put<double>(r.stamp);
  PutPose(out, r.pose);
  out.Put<int32_t>(r.first_tracked);
  const FrameFeatures& f = r.features;
  out.Put<uint32_t>(static_cast<uint32_t>(f.size()));
  for (int i = 0; i < f.size(); ++i) {
    out.Put<float>(f.pixels[i].x);
    out.Put<float>(f.pixels[i].y);
    out.Put<double>(f.normalized[i].x());
    out.Put<double>(f.normalized[i].y());
    out.Put<uint8_t>(f.depth[i].has_value());
    out.Put<double>(f.depth[i].value_or(0));
    for (int b = 0; b < 32; ++b) out.Put<uint8_t>(f.descriptors.at<uint8_t>(i, b));
  }
  out.Put<uint8_t>(!r.roles.empty());
  if (!r.roles.empty()) {
    for (int i = 0; i < f.size(); ++i) {
      out.Put<uint8_t>(static_cast<uint8_t>(r.roles[i]));
      out.Put<int32_t>(r.static_run[i]);
    }
  }
  out.Put<uint8_t>(!r.tracks.empty());
  for (int64_t track : r.tracks) out.Put<int64_t>(track);
}

bool GetReference(BinaryReader& in, uint32_t version, Reference* r) {
  uint32_t n = 0;
  if (!in.Get(&r->id) || !in.Get(&r->stamp) || !GetPose(in, &r->pose) ||
      !in.Get(&r->first_tracked) || !in.Get(&n) || n > kMaxStoredFeatures) {
    return false;
  }
  FrameFeatures& f = r->features;
  f.descriptors = cv::Mat(static_cast<int>(n), 32, CV_8U);
  for (uint32_t i = 0; i < n; ++i) {
    float px = 0, py = 0;
    double nx = 0, ny = 0, depth = 0;
    uint8_t has_depth = 0;
    if (!in.Get(&px) || !in.Get(&py) || !in.Get(&nx) || !in.Get(&ny) || !in.Get(&has_depth) ||
        !in.Get(&depth) || !std::isfinite(nx) || !std::isfinite(ny) ||
        (has_depth && !(std::isfinite(depth) && depth > 0))) {
      return false;
    }
    f.pixels.emplace_back(px, py);
    f.normalized.emplace_back(nx, ny);
    f.depth.push_back(has_depth ? std::optional<double>(depth) : std::nullopt);
    for (int b = 0; b < 32; ++b) {
      if (!in.Get(&f.descriptors.at<uint8_t>(static_cast<int>(i), b))) return false;
    }
  }
  uint8_t has_roles = 0;
  if (!in.Get(&has_roles)) return false;
  if (has_roles) {
    for (uint32_t i = 0; i < n; ++i) {
      uint8_t role = 0;
      int32_t run = 0;
      if (!in.Get(&role) || !in.Get(&run) || role > static_cast<uint8_t>(ReferenceRole::kProven)) {
        return false;
      }
      r->roles.push_back(static_cast<ReferenceRole>(role));
      r->static_run.push_back(run);
    }
  }
  if (version < 2) return true;
  uint8_t has_tracks = 0;
  if (!in.Get(&has_tracks)) return false;
  if (has_tracks) {
    for (uint32_t i = 0; i < n; ++i) {
      int64_t track = 0;
      if (!in.Get(&track) || track < -1) return false;
      r->tracks.push_back(track);
    }
  }
  return true;
}

}  // namespace

std::string VisualOdometry::SerializeState() {
  State& s = *state_;
  // A running adjustment is finished and applied first, as the next frame would, so that the
  // checkpoint holds it.
  StageTimings unused;
  ApplyBundle(/*wait=*/true, &unused);
  BinaryWriter out;
  out.Put<uint32_t>(kStateMagic);
  out.Put<uint32_t>(kStateVersion);
  out.Put<uint8_t>(s.with_depth.has_value());
  out.Put<uint8_t>(s.with_depth.value_or(false));
  out.Put<uint8_t>(s.last_stamp.has_value());
  out.Put<double>(s.last_stamp.value_or(0));
  PutOptionalPose(out, s.last_pose);
  PutOptionalPose(out, s.previous_pose);
  out.Put<double>(s.mono_speed);
  out.Put<int64_t>(s.next_keyframe_id);
  for (const std::deque<Reference>* list : {&s.keyframes, &s.archive}) {
    out.Put<uint32_t>(static_cast<uint32_t>(list->size()));
    for (const Reference& r : *list) PutReference(out, r);
  }
  out.Put<uint8_t>(s.local_map.has_value());
  if (s.local_map) s.local_map->Save(out);
  return out.Take();
}

absl::Status VisualOdometry::RestoreState(const std::string& bytes) {
  const auto lost = [] {
    return absl::DataLossError(
        "not a visual odometry state this build reads (truncated or corrupt)");
  };
  BinaryReader in(bytes);
  uint32_t magic = 0, version = 0;
  if (!in.Get(&magic) || magic != kStateMagic || !in.Get(&version) || version < 1 ||
      version > kStateVersion) {
    return lost();
  }
  uint8_t has_depth = 0, with_depth = 0, has_stamp = 0;
  double stamp = 0, mono_speed = 1;
  int64_t next_id = 0;
  std::optional<Pose> last, previous;
  if (!in.Get(&has_depth) || !in.Get(&with_depth) || !in.Get(&has_stamp) || !in.Get(&stamp) ||
      !GetOptionalPose(in, &last) || !GetOptionalPose(in, &previous) || !in.Get(&mono_speed) ||
      !in.Get(&next_id) || !std::isfinite(stamp) || !std::isfinite(mono_speed)) {
    return lost();
  }
  std::deque<Reference> lists[2];
  for (std::deque<Reference>& list : lists) {
    uint32_t n = 0;
    if (!in.Get(&n) || n > kMaxStoredKeyframes) return lost();
    for (uint32_t i = 0; i < n; ++i) {
      Reference r;
      if (!GetReference(in, version, &r)) return lost();
      list.push_back(std::move(r));
    }
  }
  std::optional<LocalMap> local_map;
  uint8_t has_local_map = 0;
  if (version >= 2) {
    if (!in.Get(&has_local_map)) return lost();
    if (has_local_map) {
      local_map.emplace(NewLocalMap(/*monocular=*/has_depth && !with_depth));
      if (!local_map->Load(in)) return lost();
    }
  }
  if (!in.done()) return lost();
  // A map saved by a session without the adjustment, or the reverse: tracks only mean something
  // with their window.
  if (has_depth && with_depth && options_.bundle_monocular_only) options_.bundle_window = 0;
  if (options_.bundle_window <= 0) local_map.reset();
  if (!local_map) {
    for (std::deque<Reference>& list : lists) {
      for (Reference& r : list) r.tracks.clear();
    }
  }
  State& s = *state_;
  if (s.bundle.valid()) s.bundle.wait();
  s.bundle = {};
  s.local_map = std::move(local_map);
  s.anchors.clear();
  s.with_depth = has_depth ? std::optional<bool>(with_depth != 0) : std::nullopt;
  s.last_stamp = has_stamp ? std::optional<double>(stamp) : std::nullopt;
  s.last_pose = last;
  s.previous_pose = previous;
  s.mono_speed = mono_speed;
  s.next_keyframe_id = next_id;
  s.keyframes = std::move(lists[0]);
  s.archive = std::move(lists[1]);
  return absl::OkStatus();
}

}  // namespace waymark::visual_slam
