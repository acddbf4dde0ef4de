#ifndef WAYMARK_SERVER_SERVICE_SLAM_SESSION_ENGINE_H_
#define WAYMARK_SERVER_SERVICE_SLAM_SESSION_ENGINE_H_

// What the SLAM registry needs from the engine of one session, whatever its kind (laser EKF SLAM,
// visual odometry): admit a message on the stream's thread, process it on the session's strand,
// and hand over what a checkpoint stores and the read RPCs return. The registry owns the queue,
// the strand, time order, counters and checkpoints; an adapter per kind owns the conversions
// (laser_session_engine.h, visual_session_engine.h).

#include <cstddef>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "server/service/slam/folder.h"
#include "storage/slam_store.h"
#include "waymark/v1/slam.pb.h"

namespace waymark::service {

// A message converted to the engine's input types at admission. Each adapter downcasts its own.
struct EngineInput {
  virtual ~EngineInput() = default;
};

struct AdmittedMessage {
  // Scans and frames are answered with a SlamUpdate (and windowed by clients); odometry is
  // answered only when rejected. Each of the two streams of stamps must strictly increase.
  bool answered = false;
  const char* sensor = "";  // "scan", "odometry", "frame": for order errors
  double stamp = 0;
  size_t bytes = 0;  // memory the input holds while queued (decoded frames; 0 for laser)
  std::unique_ptr<EngineInput> input;
};

class SessionEngine {
 public:
  virtual ~SessionEngine() = default;

  virtual const char* kind() const = 0;  // "laser" or "visual", as stored

  // Converts and validates a message on the stream's thread, while the strand may be processing
  // an earlier one: implementations read only what is fixed at creation. INVALID_ARGUMENT, naming
  // the field, for a payload the session cannot take.
  virtual absl::StatusOr<AdmittedMessage> Admit(const v1::SensorData& data) const = 0;

  // Processes an admitted input on the strand. For answered messages the update with the engine's
  // part filled (the registry sets sequence and scans_processed); nullopt for the others. An error
  // leaves the session as it was.
  virtual absl::StatusOr<std::optional<v1::SlamUpdate>> Process(EngineInput& input,
                                                                double queue_ms) = 0;

  // Checkpoint: the opaque state bytes and the trajectory (seq 0, 1, ...), the stored part
  // included.
  virtual std::string SerializeState() const = 0;
  virtual int64_t trajectory_size() const = 0;
  virtual storage::TrajectoryPoseRecord PoseRecord(int64_t seq) const = 0;

  // Read RPCs on a resident session.
  virtual void AppendTrajectory(v1::Trajectory* out) const = 0;
  // FAILED_PRECONDITION for kinds without a segment map.
  virtual absl::Status FillMap(v1::SegmentMap* map) const = 0;
  // The occupancy grid (laser sessions with kept scans); FAILED_PRECONDITION otherwise.
  virtual absl::Status FillOccupancyGrid(double resolution, v1::OccupancyGrid* grid) const {
    return absl::FailedPreconditionError(
        absl::StrCat("a ", kind(), " session has no occupancy grid"));
  }
  // The self-check of the map as it stands (laser sessions that keep scans), contradicting cells
  // included; FAILED_PRECONDITION for sessions without one. Not const: the laser engine keeps what
  // the last check cast, so that the next one redoes only what moved.
  virtual absl::Status CheckMap(v1::MapSelfCheck* check) {
    return absl::FailedPreconditionError(
        absl::StrCat("a ", kind(), " session has no map self-check"));
  }
  // Called once before the final checkpoint of CloseSession: finish background work (the laser
  // back end's last optimisation) so that the closed session holds its final map.
  virtual void Finish() {}
  // Sets the session's config (laser or visual, as it is echoed) and kind in `out`.
  virtual void DescribeConfig(v1::Session* out) const = 0;
};

// The trajectory pose of a stored row: a 3-D pose (pose3d) when the row has one, else the laser
// pose and covariance.
v1::TrajectoryPose TrajectoryPoseFromRecord(const storage::TrajectoryPoseRecord& record);

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_SLAM_SESSION_ENGINE_H_
