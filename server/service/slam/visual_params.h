#ifndef WAYMARK_SERVER_SERVICE_SLAM_VISUAL_PARAMS_H_
#define WAYMARK_SERVER_SERVICE_SLAM_VISUAL_PARAMS_H_

// Translation between the visual session messages of the SLAM API and the visual odometry
// engine's types (server/visual_slam), with validation messages that name the field, the value
// and the allowed range. Unset optional parameters take the engine defaults
// (server/visual_slam/options.h).

#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "server/service/slam/folder.h"
#include "server/visual_slam/detectors/detector_factory.h"
#include "server/visual_slam/options.h"
#include "server/visual_slam/types.h"
#include "waymark/v1/slam.pb.h"

namespace waymark::service {

// Largest camera the service takes (pixels per side): frames are decoded in memory, and a frame of
// 8192 x 8192 colour already needs 200 MB.
inline constexpr int kMaxCameraSide = 8192;
inline constexpr double kDefaultDepthScale = 5000;  // TUM and Bonn RGB-D

struct VisualSessionOptions {
  visual_slam::VisualOdometryOptions odometry;
  visual_slam::CameraModel camera;
  visual_slam::DetectorChoice detector;
};

// Validates a CreateSessionRequest.visual config and returns it with every unset parameter set to
// the engine default and detector.model_files summarizing the model bytes (which stay: the stored
// config must rebuild the detector after a restart). INVALID_ARGUMENT naming the field.
absl::StatusOr<v1::VisualSlamConfig> EffectiveVisualConfig(const v1::VisualSlamConfig& config);

// The engine options of an effective config; validated.
absl::StatusOr<VisualSessionOptions> ToVisualSessionOptions(const v1::VisualSlamConfig& config);

// The config as Session echoes it: without the model bytes (model_files says what they were).
v1::VisualSlamConfig EchoVisualConfig(v1::VisualSlamConfig config);

v1::Pose3D ToProtoPose3D(const visual_slam::Pose& pose);
visual_slam::Pose FromProtoPose3D(const v1::Pose3D& pose);

// INVALID_ARGUMENT for a box with a non-finite or negative size or non-finite corner.
absl::StatusOr<visual_slam::Box> FromProtoBox(const v1::BoundingBox& box);
v1::BoundingBox ToProtoBox(const visual_slam::Box& box);

// Fills pose3d and visual (state, keyframe, counts, timings, boxes; the features when
// `want_features`) of `update`. decode_ms and queue_ms come from the service.
void FillVisualUpdate(const visual_slam::FrameResult& result, bool want_features, double decode_ms,
                      double queue_ms, v1::SlamUpdate* update);

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_SLAM_VISUAL_PARAMS_H_
