#ifndef WAYMARK_SERVER_LASER_SLAM_LASER_SLAM_H_
#define WAYMARK_SERVER_LASER_SLAM_LASER_SLAM_H_

// One laser SLAM session: odometry and scans in (each stream in time order), pose and segment map
// out. Plain C++ and Eigen; the service owns threads, queues and storage.

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "server/laser_slam/exploration_types.h"
#include "server/laser_slam/options.h"
#include "server/laser_slam/types.h"

namespace waymark::laser_slam {

struct StageMs {
  double extraction = 0.0;
  double prediction = 0.0;
  double association = 0.0;
  double update = 0.0;
  double total = 0.0;
};

// What one scan did to the session.
struct ScanUpdate {
  PoseEstimate pose;
  bool skipped = false;       // too little motion since the last processed scan (options)
  int observed = 0;           // segments extracted from the scan
  int matched = 0;            // ... that matched a map segment
  int added = 0;              // ... added as new map segments
  int merged = 0;             // map segments merged into others after this scan
  int segments = 0;           // map segments now (active + frozen)
  int active_segments = 0;    // ... of which in the filter
  int state_size = 0;         // dimension of the EKF state
  std::uint64_t map_revision = 0;  // increases whenever the map changes
  // Mean of the diagonal of the filter covariance (robot and active segments): the paper's
  // uncertainty measure ("mean covariance trace").
  double covariance_trace_mean = 0.0;
  // The next control, in active and wander sessions (options.exploration.mode).
  std::optional<Suggestion> suggestion;
  StageMs timings;
};

class LaserSlam {
 public:
  // `options` must pass ValidateSlamOptions.
  explicit LaserSlam(const SlamOptions& options);
  ~LaserSlam();
  LaserSlam(const LaserSlam&) = delete;
  LaserSlam& operator=(const LaserSlam&) = delete;

  // Odometry stamps must strictly increase (INVALID_ARGUMENT otherwise; the session is unchanged).
  absl::Status AddOdometry(const OdometryReading& reading);

  // Scan stamps must strictly increase; the geometry must pass ValidateScanGeometry and match the
  // range count. The robot motion since the previous scan comes from the odometry interpolated at
  // the scan stamps (the latest reading when the scan is newer than all odometry).
  absl::StatusOr<ScanUpdate> AddScan(const LaserScan& scan);

  PoseEstimate CurrentPose() const;
  // What the exploration planner needs: pose, covariances, map, last scan.
  ExplorationView View() const;
  std::vector<MapSegment> Map() const;
  const std::vector<PoseEstimate>& Trajectory() const;
  std::uint64_t map_revision() const;
  std::uint64_t scans_processed() const;
  const SlamOptions& options() const;

  // Everything needed to continue the session, except the trajectory (stored separately so that a
  // periodic checkpoint appends poses instead of rewriting them). Versioned binary.
  std::string SerializeState() const;
  // Rebuilds a session from SerializeState() bytes and the trajectory stored beside them.
  static absl::StatusOr<std::unique_ptr<LaserSlam>> FromCheckpoint(
      const SlamOptions& options, absl::string_view state, std::vector<PoseEstimate> trajectory);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_LASER_SLAM_H_
