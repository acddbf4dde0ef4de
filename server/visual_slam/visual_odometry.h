#ifndef WAYMARK_SERVER_VISUAL_SLAM_VISUAL_ODOMETRY_H_
#define WAYMARK_SERVER_VISUAL_SLAM_VISUAL_ODOMETRY_H_

// One visual odometry session (METHODS.md section 3): ORB features per frame, detector boxes split
// them into potentially dynamic and not (eq 7), coarse Hamming matching to the reference keyframe
// (eq 8), a motion model from the features outside boxes by sequential sampling with the previous
// motion as tie-break (eq 10-12), the pose (essential matrix, eq 14-15, monocular; PnP + refinement
// on the reference's depth, RGB-D), the static test on every match (eq 17), tracking on all static
// features and mapping on the static ones outside boxes (eq 18). A small local map of recent
// keyframes lets tracking survive frames where most features sit on people.
//
// RGB-D sessions give metric poses. Monocular sessions give scale-free poses: the first motion has
// unit length and later ones keep the scale by triangulation against the previous keyframe pair.
//
// Not thread-safe: one caller (the session's strand) at a time.

#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "server/visual_slam/detectors/object_detector.h"
#include "server/visual_slam/options.h"
#include "server/visual_slam/types.h"

namespace waymark::visual_slam {

struct FrameFeatures;
struct Reference;
struct TrackingOutcome;

class LocalMap;

class VisualOdometry {
 public:
  // INVALID_ARGUMENT for bad options or a camera without positive focal lengths and size.
  // `detector` may be null (no detector: only robot-supplied boxes split features).
  static absl::StatusOr<std::unique_ptr<VisualOdometry>> Create(
      const VisualOdometryOptions& options, const CameraModel& camera,
      std::unique_ptr<ObjectDetector> detector);
  ~VisualOdometry();

  // Processes the next frame. INVALID_ARGUMENT (and the session is unchanged) for a frame whose
  // stamp is not after the last one, an image of the wrong size or type, a depth image of the
  // wrong size or type, non-finite stamps or boxes. A detector failure is reported the same way.
  absl::StatusOr<FrameResult> ProcessFrame(const FrameInput& frame);

  // Every processed frame's pose, in order.
  const std::vector<TimedPose>& trajectory() const { return trajectory_; }
  // Restarts tracking from `pose` (after a server restart the service resumes a session from its
  // last stored pose: the next frame becomes a keyframe at that pose).
  void ResetAt(const TimedPose& pose);
  // The session's map for a checkpoint: the local map's keyframes and the archived ones (their
  // features, poses, roles, tracks), the bundle adjustment's window and points, the motion model
  // and the last stamp. An adjustment still running is waited for and applied first (as the next
  // frame would apply it), so a restored session answers as the uninterrupted one.
  std::string SerializeState();
  // Puts a session made with the same options and camera back where SerializeState left it.
  // DATA_LOSS for bytes that are not such a state (the session is then unchanged).
  absl::Status RestoreState(const std::string& bytes);

  const VisualOdometryOptions& options() const { return options_; }
  const CameraModel& camera() const { return camera_; }

 private:
  struct State;
  VisualOdometry(const VisualOdometryOptions& options, const CameraModel& camera,
                 std::unique_ptr<ObjectDetector> detector);
  // The local bundle adjustment: starts one on the window after a new keyframe (if none runs),
  // and applies a finished one (waiting for it when `wait`) to keyframes, references, the
  // trajectory and the motion model.
  void StartBundle();
  LocalMap NewLocalMap(bool monocular) const;
  TrackingQuality Quality(const FrameResult& result, const TrackingOutcome& outcome, bool tracked,
                          bool rgbd) const;
  void ApplyBundle(bool wait, StageTimings* timings);
  // Relocalisation: tracks `features` against the archived keyframes (monocular: archived
  // frames) they match best; returns the one it tracked against (with its outcome in *outcome),
  // or null.
  Reference* Relocalize(const FrameFeatures& features, const std::vector<bool>& in_box,
                        double focal_px, bool rgbd, TrackingOutcome* outcome,
                        StageTimings* timings);

  VisualOdometryOptions options_;
  CameraModel camera_;
  std::unique_ptr<ObjectDetector> detector_;
  std::unique_ptr<State> state_;
  std::vector<TimedPose> trajectory_;
};

}  // namespace waymark::visual_slam

#endif  // WAYMARK_SERVER_VISUAL_SLAM_VISUAL_ODOMETRY_H_
