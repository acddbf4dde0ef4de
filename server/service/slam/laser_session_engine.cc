#include "server/service/slam/laser_session_engine.h"

#include <utility>

#include "absl/strings/str_cat.h"
#include "server/service/slam/map_self_check.h"

namespace waymark::service {

namespace ls = laser_slam;

namespace {

struct LaserInput final : EngineInput {
  bool is_scan = false;
  ls::OdometryReading odometry;
  ls::LaserScan scan;
};

ls::PoseEstimate FromRecord(const storage::TrajectoryPoseRecord& record) {
  ls::PoseEstimate pose;
  pose.stamp = record.stamp;
  pose.pose = ls::Pose2{record.x, record.y, record.theta};
  for (int i = 0; i < 9; ++i) pose.covariance(i / 3, i % 3) = record.covariance[i];
  return pose;
}

}  // namespace

LaserSessionEngine::LaserSessionEngine(v1::LaserSlamConfig config, LaserSessionOptions options,
                                       std::unique_ptr<ls::LaserSlam> slam)
    : config_(std::move(config)), options_(std::move(options)), slam_(std::move(slam)) {}

namespace {

// The localizer of a localization session (null for a mapping one).
absl::StatusOr<std::unique_ptr<ls::MapLocalizer>> LocalizerFor(
    const LaserSessionOptions& options, const LaserSessionEngine::MapPoints& map) {
  if (!options.localize) return std::unique_ptr<ls::MapLocalizer>();
  if (map == nullptr) {
    return absl::InternalError("a localization session was built without its map");
  }
  return ls::MapLocalizer::Create(*options.localize, *map);
}

}  // namespace

absl::StatusOr<std::unique_ptr<LaserSessionEngine>> LaserSessionEngine::Create(
    const v1::LaserSlamConfig& config, MapPoints map) {
  absl::StatusOr<LaserSessionOptions> options = ToLaserSessionOptions(config);
  if (!options.ok()) return options.status();
  absl::StatusOr<std::unique_ptr<ls::MapLocalizer>> localizer = LocalizerFor(*options, map);
  if (!localizer.ok()) return localizer.status();
  auto slam = std::make_unique<ls::LaserSlam>(options->slam, *std::move(localizer));
  return std::unique_ptr<LaserSessionEngine>(
      new LaserSessionEngine(config, *std::move(options), std::move(slam)));
}

absl::StatusOr<std::unique_ptr<LaserSessionEngine>> LaserSessionEngine::FromImportedGrid(
    const v1::LaserSlamConfig& config, ls::OccupancyGrid grid) {
  absl::StatusOr<LaserSessionOptions> options = ToLaserSessionOptions(config);
  if (!options.ok()) return options.status();
  auto slam = ls::LaserSlam::FromImportedGrid(options->slam, std::move(grid));
  return std::unique_ptr<LaserSessionEngine>(
      new LaserSessionEngine(config, *std::move(options), std::move(slam)));
}

absl::StatusOr<ls::PointCloud> LaserSessionEngine::MapPointsForLocalization() const {
  return slam_->MapPoints();
}

std::vector<ls::NodeView> LaserSessionEngine::Nodes() const {
  const ls::MappingBackend* backend = slam_->backend();
  return backend == nullptr ? std::vector<ls::NodeView>{} : backend->Nodes();
}

std::vector<ls::GraphConstraint> LaserSessionEngine::Loops() const {
  const ls::MappingBackend* backend = slam_->backend();
  std::vector<ls::GraphConstraint> loops;
  if (backend == nullptr) return loops;
  for (const ls::GraphConstraint& c : backend->Constraints()) {
    if (c.kind == ls::GraphConstraint::Kind::kLoop && c.enabled) loops.push_back(c);
  }
  return loops;
}

absl::StatusOr<std::unique_ptr<LaserSessionEngine>> LaserSessionEngine::FromCheckpoint(
    const v1::LaserSlamConfig& config, const std::string& state,
    const std::vector<storage::TrajectoryPoseRecord>& stored, MapPoints map) {
  absl::StatusOr<LaserSessionOptions> options = ToLaserSessionOptions(config);
  if (!options.ok()) return options.status();
  absl::StatusOr<std::unique_ptr<ls::MapLocalizer>> localizer = LocalizerFor(*options, map);
  if (!localizer.ok()) return localizer.status();
  std::vector<ls::PoseEstimate> trajectory;
  trajectory.reserve(stored.size());
  for (const storage::TrajectoryPoseRecord& pose : stored) trajectory.push_back(FromRecord(pose));
  absl::StatusOr<std::unique_ptr<ls::LaserSlam>> slam =
      ls::LaserSlam::FromCheckpoint(options->slam, state, std::move(trajectory),
                                    *std::move(localizer));
  if (!slam.ok()) return slam.status();
  return std::unique_ptr<LaserSessionEngine>(
      new LaserSessionEngine(config, *std::move(options), *std::move(slam)));
}

absl::StatusOr<AdmittedMessage> LaserSessionEngine::Admit(const v1::SensorData& data) const {
  auto input = std::make_unique<LaserInput>();
  AdmittedMessage admitted;
  switch (data.payload_case()) {
    case v1::SensorData::kOdometry: {
      absl::StatusOr<ls::OdometryReading> reading = ToOdometryReading(data.odometry());
      if (!reading.ok()) return reading.status();
      input->odometry = *reading;
      admitted.sensor = "odometry";
      admitted.stamp = reading->stamp;
      break;
    }
    case v1::SensorData::kScan: {
      absl::StatusOr<ls::LaserScan> scan = ToLaserScan(data.scan(), options_.geometry);
      if (!scan.ok()) return scan.status();
      input->is_scan = true;
      admitted.answered = true;
      admitted.sensor = "scan";
      admitted.stamp = scan->stamp;
      input->scan = *std::move(scan);
      break;
    }
    case v1::SensorData::kFrame:
      return absl::InvalidArgumentError(
          "this is a laser session: it takes odometry and scans, not image frames (create a "
          "session with a visual config for a camera)");
    default:
      return absl::InvalidArgumentError("SensorData has no payload: set odometry or scan");
  }
  admitted.input = std::move(input);
  return admitted;
}

absl::StatusOr<std::optional<v1::SlamUpdate>> LaserSessionEngine::Process(EngineInput& base,
                                                                          double queue_ms) {
  auto& input = static_cast<LaserInput&>(base);
  if (!input.is_scan) {
    if (absl::Status s = slam_->AddOdometry(input.odometry); !s.ok()) return s;
    return std::optional<v1::SlamUpdate>();
  }
  std::shared_ptr<ExplorationTeam> team;
  std::string team_id;
  {
    std::lock_guard<std::mutex> lock(team_mu_);
    team = team_;
    team_id = team_id_;
  }
  if (team != nullptr) slam_->SetTeammates(team->Teammates(team_id));
  absl::StatusOr<ls::ScanUpdate> result = slam_->AddScan(input.scan);
  if (!result.ok()) return result.status();
  if (team != nullptr) team->Publish(team_id, slam_->TeamSnapshot());
  v1::SlamUpdate update;
  FillSlamUpdate(*result, &update);
  update.mutable_timings()->set_queue_ms(queue_ms);
  return std::optional<v1::SlamUpdate>(std::move(update));
}

void LaserSessionEngine::SetTeam(std::shared_ptr<ExplorationTeam> team, std::string session_id) {
  std::lock_guard<std::mutex> lock(team_mu_);
  team_ = std::move(team);
  team_id_ = std::move(session_id);
}

std::string LaserSessionEngine::SerializeState() const { return slam_->SerializeState(); }

int64_t LaserSessionEngine::trajectory_size() const {
  return static_cast<int64_t>(slam_->LocalTrajectory().size());
}

storage::TrajectoryPoseRecord LaserSessionEngine::PoseRecord(int64_t seq) const {
  const ls::PoseEstimate& pose = slam_->LocalTrajectory()[static_cast<size_t>(seq)];
  storage::TrajectoryPoseRecord record;
  record.seq = seq;
  record.stamp = pose.stamp;
  record.x = pose.pose.x;
  record.y = pose.pose.y;
  record.theta = pose.pose.theta;
  for (int i = 0; i < 9; ++i) record.covariance[i] = pose.covariance(i / 3, i % 3);
  return record;
}

void LaserSessionEngine::AppendTrajectory(v1::Trajectory* out) const {
  for (const ls::PoseEstimate& pose : slam_->Trajectory()) {
    *out->add_poses() = ToProtoTrajectoryPose(pose);
  }
}

absl::Status LaserSessionEngine::FillMap(v1::SegmentMap* map) const {
  for (const ls::MapSegment& segment : slam_->Map()) *map->add_segments() = ToProtoSegment(segment);
  if (const ls::MappingBackend* backend = slam_->backend()) {
    const ls::MappingStats stats = backend->Stats();
    map->set_graph_nodes(static_cast<uint32_t>(stats.nodes));
    map->set_pruned_nodes(static_cast<uint32_t>(stats.nodes_pruned));
    map->set_loop_closures(static_cast<uint32_t>(backend->loop_closures()));
  }
  return absl::OkStatus();
}

absl::Status LaserSessionEngine::FillOccupancyGrid(double resolution,
                                                   v1::OccupancyGrid* out) const {
  // One answer must fit gRPC's message limit (32 MB, 1 byte per cell) and the rendering's memory
  // (6 bytes per cell) stay modest: larger maps come at a coarser resolution (`resolution` of the
  // answer). fr-clinic (42 M cells at 5 cm) and Killian (35 M) come at 7-8 cm.
  constexpr std::int64_t kMaxGridCells = 16'000'000;
  absl::StatusOr<ls::OccupancyGrid> grid = slam_->RenderGrid(resolution, kMaxGridCells);
  if (!grid.ok()) return grid.status();
  const std::string session_id = out->session_id();
  const uint64_t revision = out->map_revision();
  *out = ToProtoGrid(*grid);
  out->set_session_id(session_id);
  out->set_map_revision(revision);
  out->set_scans(static_cast<uint32_t>(slam_->backend() ? slam_->backend()->Stats().nodes : 0));
  return absl::OkStatus();
}

absl::Status LaserSessionEngine::CheckMap(v1::MapSelfCheck* check) {
  absl::StatusOr<ls::MapConsistencyReport> report = slam_->CheckMap();
  if (!report.ok()) return report.status();
  *check = ToProtoMapSelfCheck(*report, kMaxMapCheckAreas, kMaxMapCheckCells);
  return absl::OkStatus();
}

void LaserSessionEngine::Finish() { slam_->FlushBackend(); }

void LaserSessionEngine::DescribeConfig(v1::Session* out) const {
  *out->mutable_laser() = config_;
  out->set_kind("laser");
}

}  // namespace waymark::service
