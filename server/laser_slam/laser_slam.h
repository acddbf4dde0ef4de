#ifndef WAYMARK_SERVER_LASER_SLAM_LASER_SLAM_H_
#define WAYMARK_SERVER_LASER_SLAM_LASER_SLAM_H_

// One laser SLAM session: odometry and scans in (each stream in time order), pose and segment map
// out. Plain C++, Eigen and Ceres; the service owns queues and storage.
//
// Frames. The EKF (the paper's method) estimates poses in its own "local" frame, which drifts.
// With the loop-closing back end on (options.mapping.enabled, mapping/mapping_backend.h), every
// pose and segment this class returns is in the "map" frame: the local one corrected by the pose
// graph as it stood when the answer was made (ScanUpdate) or now (Trajectory, Map). With the back
// end off the two frames are the same.

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "server/laser_slam/exploration/exploration_types.h"
#include "server/laser_slam/exploration/goal_layer.h"
#include "server/laser_slam/mapping/localizer.h"
#include "server/laser_slam/mapping/map_consistency.h"
#include "server/laser_slam/mapping/mapping_backend.h"
#include "server/laser_slam/mapping/occupancy_grid.h"
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
  // The odometry jumped more than kMaxOdometryStepM since the last processed scan: taken for a
  // reset of the base's odometry, so no motion was applied (input_bounds.h).
  bool odometry_reset = false;
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
  // Where exploration stands (goal layer sessions: ACTIVE with goal_layer, FRONTIER); its target
  // and path in the map frame.
  std::optional<GoalProgress> exploration;
  // Loop-closing back end (options.mapping): loop constraints in the graph so far, and
  // the revision of the pose graph (increases with every optimisation that moved the map).
  int loop_closures = 0;
  std::uint64_t graph_revision = 0;
  // Localization sessions: how the pose was found.
  std::optional<LocalizationResult> localization;
  StageMs timings;
};

class LaserSlam {
 public:
  // `options` must pass ValidateSlamOptions. With a `localizer` the session localizes on that
  // fixed map (no back end, whatever options.mapping says); poses are in the map's frame.
  explicit LaserSlam(const SlamOptions& options, std::unique_ptr<MapLocalizer> localizer = nullptr);
  // A session that holds only an imported occupancy grid (closed at once; a map to localize on).
  static std::unique_ptr<LaserSlam> FromImportedGrid(const SlamOptions& options,
                                                     OccupancyGrid grid);
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
  // Several robots exploring one map (exploration/shared_exploration.h): the others as the next
  // decision sees them, each Teammate::to_here into this session's frame (the map frame of its
  // answers); AddScan moves them on into the planner's frame. Kept until set again.
  void SetTeammates(std::vector<Teammate> teammates);
  // This session's exploration after its last decision, for its teammates; null without a goal
  // layer or before the first decision.
  std::shared_ptr<const ExplorationSnapshot> TeamSnapshot() const;
  // What the exploration planner needs: pose, covariances, map, last scan, in the EKF's local
  // frame (the planner steers by what the robot sees around it; a loop closure does not move it).
  ExplorationView View() const;
  // Segments in the map frame: each moved by the back end's correction at the scan that last
  // matched it.
  std::vector<MapSegment> Map() const;
  // The same segments in the EKF's local frame.
  std::vector<MapSegment> LocalMap() const;
  // One pose per scan, in the map frame (recomputed from the local poses and the current graph).
  std::vector<PoseEstimate> Trajectory() const;
  // The same poses in the EKF's local frame, as checkpoints store them.
  const std::vector<PoseEstimate>& LocalTrajectory() const;
  // Waits for the back end's thread and runs a last optimisation (no-op without a back end).
  void FlushBackend();
  // Nullptr when the back end is off.
  const MappingBackend* backend() const;
  // The occupancy grid of the kept scans at their optimised poses (or the imported grid).
  // FAILED_PRECONDITION without a back end (the paper's EKF keeps no scans).
  // At most `max_cells` cells: a coarser resolution is chosen when the map needs it (the grid's
  // resolution says which).
  absl::StatusOr<OccupancyGrid> RenderGrid(double resolution,
                                           std::int64_t max_cells = kMaxOccupancyCells) const;
  // The map as points in the map frame, for localizing on it: the kept scans at their optimised
  // poses, or an imported grid's occupied cells. FAILED_PRECONDITION as RenderGrid.
  absl::StatusOr<PointCloud> MapPoints() const;
  // The map's self-check (mapping/map_consistency.h) of the graph as it stands, its nodes grouped
  // into submaps as the back end groups them. After FlushBackend it is the final map's. The
  // session keeps the checker between calls, so that the next check casts again only the submaps
  // that gained nodes or moved (an optimisation moves most of them by less than that); it holds
  // about a byte per cell each submap covers from the first call on. FAILED_PRECONDITION without
  // a back end (no scans kept). Not const for that cache, and not thread-safe, as AddScan.
  absl::StatusOr<MapConsistencyReport> CheckMap();
  std::uint64_t map_revision() const;
  std::uint64_t scans_processed() const;
  const SlamOptions& options() const;

  // Everything needed to continue the session, except the trajectory (stored separately so that a
  // periodic checkpoint appends poses instead of rewriting them). Versioned binary.
  std::string SerializeState() const;
  // Rebuilds a session from SerializeState() bytes and the trajectory stored beside them.
  // A localization session passes its localizer (built on the same map); its state is restored.
  static absl::StatusOr<std::unique_ptr<LaserSlam>> FromCheckpoint(
      const SlamOptions& options, absl::string_view state, std::vector<PoseEstimate> trajectory,
      std::unique_ptr<MapLocalizer> localizer = nullptr);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace waymark::laser_slam

#endif  // WAYMARK_SERVER_LASER_SLAM_LASER_SLAM_H_
