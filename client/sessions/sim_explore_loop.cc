#include "client/sessions/sim_explore_loop.h"

#include <filesystem>

#include "client/datasets/carmen_keyframes.h"
#include "client/sim/sim_geometry.h"

namespace waymark::cli {

adapters::SimOptions SimOptionsFor(const ExploreOptions& options) {
  adapters::SimOptions sim_options;
  sim_options.seed = options.seed;
  sim_options.half_degree = options.half_degree;
  // The simulated base drives as fast as the planner is told it may (the paper's limits unless
  // --exploration sets others): a planner that plans 0.3 m/s arcs for a 0.15 m/s base would
  // plan for places the robot never reaches.
  if (options.exploration.has_max_linear()) sim_options.max_linear = options.exploration.max_linear();
  if (options.exploration.has_max_angular()) {
    sim_options.max_angular = options.exploration.max_angular();
  }
  adapters::OdometryError& e = sim_options.odometry;
  const double k = options.odometry_error;
  e.distance_scale = 1.0 + k * (e.distance_scale - 1.0);
  e.turn_scale = 1.0 + k * (e.turn_scale - 1.0);
  e.drift_per_m *= k;
  e.distance_sigma *= k;
  e.turn_sigma *= k;
  e.turn_per_m_sigma *= k;
  return sim_options;
}

void RecordAnswer(const v1::SlamUpdate& update, ScanRecord* record) {
  if (update.covariance_size() == 9) {
    record->robot_cov_trace = update.covariance(0) + update.covariance(4) + update.covariance(8);
  }
  record->cov_trace_mean = update.covariance_trace_mean();
  record->segments = update.segments();
  record->loop_closures = update.loop_closures();
  record->suggestion = update.suggestion();
  record->exploration = update.exploration();
}

v1::CreateSessionRequest SessionRequest(const adapters::Simulation& sim,
                                        const adapters::World& world,
                                        const ExploreOptions& options,
                                        const std::string& robot_id) {
  v1::CreateSessionRequest request = LaserSessionRequest(
      sim.laser_layout(), robot_id,
      !options.session_name.empty()
          ? options.session_name
          : fmt::format("sim explore {} {} s{}", world.name, RunModeName(options), options.seed),
      options.mode);
  v1::ExplorationConfig* exploration = request.mutable_laser()->mutable_exploration();
  exploration->MergeFrom(options.exploration);
  exploration->set_mode(options.mode);
  if (options.mode == v1::ExplorationConfig::ACTIVE && !options.goal_layer) {
    exploration->set_goal_layer(false);
  }
  return request;
}

absl::StatusOr<std::unique_ptr<std::ofstream>> OpenRecording(const ExploreOptions& options,
                                                              int k) {
  if (options.record_dir.empty()) return nullptr;
  std::error_code ec;
  std::filesystem::create_directories(options.record_dir, ec);
  const std::string path = fmt::format("{}/robot{}.clf", options.record_dir, k);
  auto out = std::make_unique<std::ofstream>(path);
  if (ec || !*out) return absl::PermissionDeniedError("cannot write '" + path + "'");
  *out << "# waymark sim explore: one simulated robot's odometry and scans as sent\n";
  return out;
}

void SimRobotLink::RecordScan(const std::vector<float>& ranges) {
  const adapters::BasePose odometry = sim_.odometry_pose();
  const adapters::BasePose laser =
      adapters::geometry::Compose(odometry, sim_.laser_layout().mount);
  adapters::CarmenLaser line;
  line.stamp = sim_.now();
  line.ranges = ranges;
  line.laser_pose = adapters::CarmenPose{laser.x, laser.y, laser.theta};
  line.odom_pose = adapters::CarmenPose{odometry.x, odometry.y, odometry.theta};
  *log_ << adapters::FormatFlaserLine(line, "sim") << "\n";
}

}  // namespace waymark::cli
