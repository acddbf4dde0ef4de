#ifndef WAYMARK_SERVER_SERVICE_SLAM_VISUAL_SESSION_ENGINE_H_
#define WAYMARK_SERVER_SERVICE_SLAM_VISUAL_SESSION_ENGINE_H_

// SessionEngine of a visual odometry session (METHODS.md section 3): image frames in (decoded and
// checked at admission, visual_frame_decoder.h), VisualOdometry in between, 3-D camera poses with
// feature counts and stage timings out.
//
// Checkpoints hold the engine's map (VisualOdometry::SerializeState: the local map's keyframes,
// the archived ones kept for relocalisation, the bundle adjustment's window and points, the
// motion model); the trajectory is stored row by
// row beside it. A resumed session tracks its next frame against the keyframes it had. A v1
// checkpoint (older builds: a version marker only) resumes at the last stored pose with an empty
// map (VisualOdometry::ResetAt), the first frame after it becoming a keyframe there.

#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "server/service/slam/folder.h"
#include "server/service/slam/session_engine.h"
#include "server/service/slam/visual_params.h"
#include "server/visual_slam/visual_odometry.h"
#include "storage/slam_store.h"
#include "waymark/v1/slam.pb.h"

namespace waymark::service {

class VisualSessionEngine final : public SessionEngine {
 public:
  // `config` is the effective config (EffectiveVisualConfig) with the model bytes. Builds the
  // detector: INVALID_ARGUMENT "detector: ..." for a model OpenCV cannot load.
  static absl::StatusOr<std::unique_ptr<VisualSessionEngine>> Create(
      const v1::VisualSlamConfig& config);
  // A session resumed after a restart: `stored` is its stored trajectory; tracking goes on from
  // the checkpoint's map (v1: restarts at the last stored pose). DATA_LOSS for a checkpoint this
  // build does not know or a corrupt map.
  static absl::StatusOr<std::unique_ptr<VisualSessionEngine>> Resume(
      const v1::VisualSlamConfig& config, const std::string& state,
      std::vector<storage::TrajectoryPoseRecord> stored);

  const char* kind() const override { return "visual"; }
  absl::StatusOr<AdmittedMessage> Admit(const v1::SensorData& data) const override;
  absl::StatusOr<std::optional<v1::SlamUpdate>> Process(EngineInput& input,
                                                        double queue_ms) override;
  std::string SerializeState() const override;
  int64_t trajectory_size() const override;
  storage::TrajectoryPoseRecord PoseRecord(int64_t seq) const override;
  void AppendTrajectory(v1::Trajectory* out) const override;
  absl::Status FillMap(v1::SegmentMap* map) const override;
  void DescribeConfig(v1::Session* out) const override;

 private:
  VisualSessionEngine(v1::VisualSlamConfig config, VisualSessionOptions options,
                      std::unique_ptr<visual_slam::VisualOdometry> odometry);

  const v1::VisualSlamConfig config_;
  const VisualSessionOptions options_;  // the camera is read by Admit on the stream's thread
  std::unique_ptr<visual_slam::VisualOdometry> odometry_;
  std::vector<storage::TrajectoryPoseRecord> resumed_;  // poses from before a restart
};

// The refusal GetMap answers for a visual session.
absl::Status NoSegmentMapError();

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_SLAM_VISUAL_SESSION_ENGINE_H_
