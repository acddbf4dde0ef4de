#ifndef WAYMARK_SERVER_SERVICE_LIVE_LIVE_MESSAGES_H_
#define WAYMARK_SERVER_SERVICE_LIVE_LIVE_MESSAGES_H_

// The live view's messages, as JSON by the schemas of live_schemas.h, built from what the session
// answers carry (slam.proto's SlamUpdate, OccupancyGrid, Trajectory; crossing.proto's
// RecognizeResponse). Pure functions: no locks, no I/O. Everything is in the frame "map" (the
// session's map frame; a visual session's poses as its answers give them).

#include <cstdint>
#include <string>
#include <vector>

#include "server/service/live/folder.h"
#include "waymark/v1/crossing.pb.h"
#include "waymark/v1/slam.pb.h"

namespace waymark::service::live {

inline constexpr const char* kMapFrame = "map";

// A scan as the robot sent it (SensorData.scan), kept until its answer comes (live_hub.h).
struct ScanSample {
  uint64_t sequence = 0;
  double stamp = 0;
  double angle_min = 0;
  double angle_increment = 0;
  double no_return_range = 0;  // LaserGeometry.no_return_range (0 = none)
  std::vector<float> ranges;
};

// Nanoseconds of a stamp in seconds, for the protocol's message log time (0 for a negative or
// non-finite stamp).
uint64_t StampNanos(double stamp);

// foxglove.PoseInFrame of the answer's pose (Pose2D for laser sessions, pose3d for visual ones).
std::string PoseJson(const v1::SlamUpdate& update);

// foxglove.LaserScan: the scan drawn from the laser's pose (the robot's pose from the answer to
// this scan, composed with the laser's mounting `laser_pose`). Beams with no return (not finite,
// <= 0, or at least the geometry's no_return_range) are sent as 0: JSON has no NaN or infinity.
std::string ScanJson(const ScanSample& scan, const v1::Pose2D& robot,
                     const v1::Pose2D& laser_pose);

// foxglove.Grid of an occupancy grid: one INT8 field "occupancy" (-1 unknown, 0..100, as
// GetOccupancyGrid's cells), rows from the origin up, data in base64.
std::string GridJson(const v1::OccupancyGrid& grid, double stamp);

// foxglove.PosesInFrame of a trajectory, every k-th pose so that at most `max_poses` go out (the
// last pose always).
std::string TrajectoryJson(const v1::Trajectory& trajectory, double stamp, size_t max_poses);

// waymark.LoopClosures: the answer's count, and how many are new since `previous`.
std::string LoopClosuresJson(const v1::SlamUpdate& update, uint32_t previous);

// waymark.Confidence: the covariance and its sigmas, the localization status or the visual
// tracking quality, when the answer has them.
std::string ConfidenceJson(const v1::SlamUpdate& update);

// waymark.VisualFrame: a visual session's frame: tracking state, features per class, boxes, pose.
std::string VisualFrameJson(const v1::SlamUpdate& update);

// waymark.Recognition: a crossing recognition answer (without its candidate list).
std::string RecognitionJson(const std::string& database, const v1::RecognizeResponse& response,
                            double received_stamp);

}  // namespace waymark::service::live

#endif  // WAYMARK_SERVER_SERVICE_LIVE_LIVE_MESSAGES_H_
