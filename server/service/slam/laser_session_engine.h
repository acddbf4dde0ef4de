#ifndef WAYMARK_SERVER_SERVICE_SLAM_LASER_SESSION_ENGINE_H_
#define WAYMARK_SERVER_SERVICE_SLAM_LASER_SESSION_ENGINE_H_

// SessionEngine of a laser SLAM session (METHODS.md section 2): odometry and scans in, the
// line-segment EKF SLAM (server/laser_slam) in between, poses and map revisions out. The
// conversions and their error messages are slam_params.h's.

#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "server/laser_slam/laser_slam.h"
#include "server/service/slam/exploration_team.h"
#include "server/service/slam/folder.h"
#include "server/service/slam/session_engine.h"
#include "server/service/slam/slam_params.h"
#include "storage/slam_store.h"
#include "waymark/v1/slam.pb.h"

namespace waymark::service {

class LaserSessionEngine final : public SessionEngine {
 public:
  // The points of the map a localization session localizes on (config.localize), found by the
  // registry from the map session's id; null for mapping sessions.
  using MapPoints = std::shared_ptr<const laser_slam::PointCloud>;

  // `config` is the effective config (EffectiveLaserConfig); a new, empty session.
  static absl::StatusOr<std::unique_ptr<LaserSessionEngine>> Create(
      const v1::LaserSlamConfig& config, MapPoints map = nullptr);
  // A session resumed from its checkpoint bytes and stored trajectory.
  static absl::StatusOr<std::unique_ptr<LaserSessionEngine>> FromCheckpoint(
      const v1::LaserSlamConfig& config, const std::string& state,
      const std::vector<storage::TrajectoryPoseRecord>& trajectory, MapPoints map = nullptr);
  // A session that holds only an imported grid.
  static absl::StatusOr<std::unique_ptr<LaserSessionEngine>> FromImportedGrid(
      const v1::LaserSlamConfig& config, laser_slam::OccupancyGrid grid);

  // The map as points for localizing on it; FAILED_PRECONDITION when the session keeps none.
  absl::StatusOr<laser_slam::PointCloud> MapPointsForLocalization() const;
  // The back end's nodes as its graph now places them (none without a back end). Thread-safe:
  // the back end serves them from any thread, so a reader need not wait for the strand.
  std::vector<laser_slam::NodeView> Nodes() const;
  // The back end's loop closures in force (enabled), by node index; none without a back end.
  std::vector<laser_slam::GraphConstraint> Loops() const;

  // Several robots exploring one map: before each scan the session takes its teammates from
  // `team`, after it publishes its own exploration there as `session_id`. Null: alone (the
  // default). Thread-safe (set when a stream opens, read on the strand).
  void SetTeam(std::shared_ptr<ExplorationTeam> team, std::string session_id);

  const char* kind() const override { return "laser"; }
  absl::StatusOr<AdmittedMessage> Admit(const v1::SensorData& data) const override;
  absl::StatusOr<std::optional<v1::SlamUpdate>> Process(EngineInput& input,
                                                        double queue_ms) override;
  std::string SerializeState() const override;
  int64_t trajectory_size() const override;
  storage::TrajectoryPoseRecord PoseRecord(int64_t seq) const override;
  void AppendTrajectory(v1::Trajectory* out) const override;
  absl::Status FillMap(v1::SegmentMap* map) const override;
  absl::Status FillOccupancyGrid(double resolution, v1::OccupancyGrid* grid) const override;
  absl::Status CheckMap(v1::MapSelfCheck* check) override;
  void Finish() override;
  void DescribeConfig(v1::Session* out) const override;

 private:
  LaserSessionEngine(v1::LaserSlamConfig config, LaserSessionOptions options,
                     std::unique_ptr<laser_slam::LaserSlam> slam);

  const v1::LaserSlamConfig config_;
  const LaserSessionOptions options_;
  std::unique_ptr<laser_slam::LaserSlam> slam_;
  mutable std::mutex team_mu_;
  std::shared_ptr<ExplorationTeam> team_;  // guarded by team_mu_
  std::string team_id_;                    // guarded by team_mu_
};

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_SLAM_LASER_SESSION_ENGINE_H_
