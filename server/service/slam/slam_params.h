#ifndef WAYMARK_SERVER_SERVICE_SLAM_SLAM_PARAMS_H_
#define WAYMARK_SERVER_SERVICE_SLAM_SLAM_PARAMS_H_

// Translation between the SLAM API's messages and the laser SLAM engine's types, with validation
// messages that name the field, the value and the allowed range, so a robot engineer knows what to
// fix. Unset optional parameters take the engine defaults (server/laser_slam/options.h).

#include <optional>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "server/laser_slam/laser_slam.h"
#include "server/laser_slam/options.h"
#include "server/laser_slam/types.h"
#include "server/service/slam/folder.h"
#include "waymark/v1/slam.pb.h"

namespace waymark::service {

// Largest scan the service accepts (beams), whatever its geometry says; matches the engine's
// ValidateScanGeometry bound.
inline constexpr int kMaxScanBeams = 10000;

struct LaserSessionOptions {
  laser_slam::SlamOptions slam;
  // The session's beam layout; beam_count == 0 when the session was created without one (then
  // every scan must carry its own geometry).
  laser_slam::ScanGeometry geometry;
  // Localization sessions (config.localize set): the map session and how to localize on it.
  std::string map_session_id;
  std::optional<laser_slam::LocalizationOptions> localize;
};

// OK when value is in [lo, hi] (or (lo, hi] when lo_open); else INVALID_ARGUMENT
// "<field> must be in [lo, hi] <unit>, got <value>".
absl::Status InRange(double value, const std::string& field, double lo, double hi, bool lo_open,
                     const char* unit);

// Validates a CreateSessionRequest.laser config and returns it with every unset parameter set to
// the engine default, as it is stored and reported. INVALID_ARGUMENT naming the field.
absl::StatusOr<v1::LaserSlamConfig> EffectiveLaserConfig(const v1::LaserSlamConfig& config);

// The engine options of a config (set fields override the engine defaults); validated.
absl::StatusOr<LaserSessionOptions> ToLaserSessionOptions(const v1::LaserSlamConfig& config);

laser_slam::ScanGeometry ToScanGeometry(const v1::LaserGeometry& geometry);
v1::LaserGeometry ToProtoGeometry(const laser_slam::ScanGeometry& geometry);

// Odometry message -> engine reading; INVALID_ARGUMENT for a non-finite stamp or pose.
absl::StatusOr<laser_slam::OdometryReading> ToOdometryReading(const v1::Odometry& odometry);

// Scan message -> engine scan, with the scan's own geometry or else `session_geometry`.
// INVALID_ARGUMENT when the stamp is not finite, there are more than kMaxScanBeams ranges, the
// geometry is invalid or missing, or the range count disagrees with the geometry's beam_count.
// Ranges are passed through as sent: NaN, infinite, negative and zero are the engine's no-returns.
absl::StatusOr<laser_slam::LaserScan> ToLaserScan(const v1::LaserScan& scan,
                                                  const laser_slam::ScanGeometry& session_geometry);

v1::Pose2D ToProtoPose(const laser_slam::Pose2& pose);
laser_slam::Pose2 FromProtoPose(const v1::Pose2D& pose);
v1::TrajectoryPose ToProtoTrajectoryPose(const laser_slam::PoseEstimate& pose);
v1::MapSegment ToProtoSegment(const laser_slam::MapSegment& segment);
laser_slam::MapSegment FromProtoSegment(const v1::MapSegment& segment);
// The engine's grid as the API's OccupancyGrid (session id and revision left to the caller), and
// back; the latter validates (INVALID_ARGUMENT naming the field).
v1::OccupancyGrid ToProtoGrid(const laser_slam::OccupancyGrid& grid);
absl::StatusOr<laser_slam::OccupancyGrid> FromProtoGrid(const v1::OccupancyGrid& grid);
// Fills the pose, counts and engine timings of `update` (not sequence, queue time or
// scans_processed, which the session owns).
void FillSlamUpdate(const laser_slam::ScanUpdate& scan_update, v1::SlamUpdate* update);

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_SLAM_SLAM_PARAMS_H_
