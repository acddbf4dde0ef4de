#ifndef WAYMARK_CLIENT_SESSIONS_SIM_EXPLORE_H_
#define WAYMARK_CLIENT_SESSIONS_SIM_EXPLORE_H_

// The closed exploration loop, simulated robot <-> SLAM server (issue 4), as a library function so
// the command line (`waymark sim explore`, sim_commands.cc) and tests share it.
//
// Protocol (the paper's go-stop motion; all stamps are simulated seconds, sim.now()):
//  1. Simulation(world, SimOptions{seed}); CreateSession(robot_id "sim", laser geometry from
//     sim.laser_layout() (angle_min, angle_increment, beam_count, no_return_range),
//     laser_pose = layout.mount, exploration.mode = ACTIVE or WANDER; every other parameter is the
//     server's default, so the service maps to its own 6 m range). One StreamSensorData with a
//     scan window of 1: the loop waits for each scan's SlamUpdate before it moves.
//  2. t = 0: Odometry(t, odometry pose), LaserScan(t, ranges); wait for the update.
//  3. While sim.now() < duration and the last update's exploration state (goal layer sessions:
//     ACTIVE with goal_layer, FRONTIER) is neither DONE nor STUCK:
//     - the update's suggestion is required: none (or BEHAVIOUR_UNSPECIFIED) is FAILED_PRECONDITION
//       "session is not in active or wander mode";
//     - hold = min(suggestion.duration, duration - now), at least one control step when
//       suggestion.duration <= 0 so time (and the stamps) always move on; the last hold is cut at
//       `duration`, so runs of different modes cover equal simulated time;
//     - SetVelocity(linear, angular), then Advance in equal steps of at most kControlStep (0.1 s),
//       sending Odometry(now, odometry pose) after each step; a step that ends with the base bumped
//       stops the hold early (counted in `early_stops`). BLOCKED (0, 0) suggestions are held the
//       same way: the robot stands while time passes;
//     - Stop(); LaserScan(now, ranges) at the stop instant (the same stamp as the last odometry,
//       which the service allows; stamps strictly increase per sensor); wait for the update.
//  4. A rejected message (odometry or scan) ends the run with the rejection's code and message. No
//     answer within `answer_timeout` is DEADLINE_EXCEEDED.
//  5. After every update: GetMap (cheap) for completeness; the session is closed at the end.
//
// Per scan it records ground truth, odometry and the estimate in the world frame (the map frame is
// the robot frame at the first scan: exploration_metrics.h), errors, uncertainty, completeness and
// the suggestion that answered it.

#include <cstdint>
#include <functional>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "client/sim/sim_world.h"
#include "client/lib/slam_client.h"
#include "client/render/map_render.h"
#include "client/datasets/tum_trajectory.h"
#include "waymark/v1/slam.pb.h"

namespace waymark::cli {

inline constexpr double kControlStep = 0.1;  // s between odometry messages while moving (paper)

struct ExploreOptions {
  v1::ExplorationConfig::Mode mode = v1::ExplorationConfig::ACTIVE;
  // ACTIVE: false is the paper's one-step planner alone (ExplorationConfig.goal_layer).
  bool goal_layer = true;
  // Set fields override the session's exploration parameters (mode and goal_layer excepted).
  v1::ExplorationConfig exploration;
  double duration_s = 300;  // simulated
  uint64_t seed = 1;
  bool half_degree = false;  // LMS200 0.5-degree mode: 361 beams instead of 181
  // Multiplies every odometry error of the simulator (systematic and random; 0 = perfect
  // odometry), SimOptions defaults at 1.
  double odometry_error = 1.0;
  std::string session_name;  // default "sim explore <world> <mode> s<seed>"
  // When set, each robot's odometry and scans as sent, as CARMEN logs DIR/robot<k>.clf (k from
  // 1): the same robot data replayed later (`waymark slam replay`) with other server settings.
  std::string record_dir;
  absl::Duration answer_timeout = absl::Seconds(120);  // per scan, planner time included
};

struct ScanRecord {
  double time = 0;       // sim time = stamp of the scan, s
  Pose2 true_pose;       // world
  Pose2 odometry_raw;    // odometry frame, as sent
  Pose2 odometry_world;  // odometry anchored at the first scan (exploration_metrics.h)
  Pose2 estimate_map;    // update.pose
  Pose2 estimate_world;
  double loc_error_m = 0;       // |true - estimate| position
  double odometry_error_m = 0;  // |true - odometry_world| position
  double robot_cov_trace = 0;   // covariance[0] + [4] + [8]
  double cov_trace_mean = 0;    // update.covariance_trace_mean
  uint32_t segments = 0;
  uint32_t loop_closures = 0;  // accepted by the back end so far
  double completeness = 0;
  v1::SuggestedControl suggestion;  // what answered this scan (executed unless it is the last)
  v1::ExplorationProgress exploration;  // goal layer sessions
};

struct ExploreResult {
  std::string world;
  std::string mode;  // "active", "paper" (ACTIVE without the goal layer), "wander", "frontier"
  uint64_t seed = 0;
  std::string session_id;
  std::vector<ScanRecord> scans;
  std::vector<SceneSegment> final_map_world;  // last GetMap, world frame
  double sim_time_s = 0;
  double distance_m = 0;  // true path length
  int collisions = 0;     // sim.collisions()
  int early_stops = 0;    // holds cut short by a bump
  uint64_t odometry_sent = 0;
  // The session said DONE or STUCK (the run stopped there; state and reason in the last scan's
  // exploration).
  bool finished = false;
  // Of the wall length the laser can see from where the robot fits (adapters::VisibleWalls): its
  // share of all wall length, and the share of it the final map covers.
  double visible_wall_share = 0;
  double completeness_visible = 0;
};

// Called after each scan is recorded (progress).
using ScanCallback = std::function<void(const ScanRecord&)>;

absl::StatusOr<ExploreResult> RunExploration(client::SlamClient& client,
                                             const adapters::World& world,
                                             const ExploreOptions& options,
                                             const ScanCallback& on_scan = {});

// "active", "wander", "passive", "frontier"; "optimal", "wall_following", "wander", "blocked",
// "to_target", "finished", "unspecified".
std::string ExplorationModeName(v1::ExplorationConfig::Mode mode);
// The name a run goes by: ExplorationModeName, except "paper" for ACTIVE without the goal layer.
std::string RunModeName(const ExploreOptions& options);
std::string BehaviourName(v1::SuggestedControl::Behaviour behaviour);

// The run's figures (summary.json and --json): completeness, loc_error_mean_m, loc_error_final_m,
// cov_trace_mean, collisions, sim_time_s, world, mode, seed, distance_m, scans, segments,
// wall_following_share (of the executed suggestions), odometry_error_final_m, planning_ms_p50,
// planning_ms_p99, completeness_300s / _600s / _1200s (at the last scan at or before that time;
// the final value when the run ended earlier), time_to_95_s and done_time_s (-1: never),
// final_state ("exploring", "done", "stuck"; "-" without the goal layer), final_reason,
// open_boundary_final, ...
// `out_dir` is added by the caller.
nlohmann::json ExploreSummary(const ExploreResult& result);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_SESSIONS_SIM_EXPLORE_H_
