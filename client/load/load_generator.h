#ifndef WAYMARK_CLIENT_LOAD_LOAD_GENERATOR_H_
#define WAYMARK_CLIENT_LOAD_LOAD_GENERATOR_H_

// The simulated fleet of `waymark bench load`: N robots against one server, each doing what a real
// robot does, at its sensor rates, on its own channel:
//  - a recognition thread: RecognizeCrossing with the next image of a shared query set, at
//    `recognize_hz` (a camera asking "where am I?"), through the client library (so a call's
//    latency includes the library's retries of UNAVAILABLE, as a robot sees it);
//  - a SLAM thread: CreateSession (passive laser session), then one StreamSensorData stream fed by
//    the built-in simulator (client/sim/sim_robot.h) in real time: odometry at
//    `odometry_hz`, laser scans at `scan_hz`, the robot wandering the world (straight on, turning
//    away from walls); at the end the stream is finished (every scan answered) and the session
//    closed.
// Ticks are scheduled on the steady clock; a tick that comes late (the server answers slowly, or
// the stream's flow-control window is full) is not made up for with a burst, so an overloaded
// server shows as fewer calls per second and longer latencies, not as a pile-up in the client.
// Robots start staggered over one period so they do not all call at the same instant.

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "client/lib/crossing_client.h"
#include "client/lib/slam_client.h"
#include "client/load/load_stats.h"

namespace waymark::cli {

// Names under which LoadRecorder keeps the robots' calls.
inline constexpr char kRecognizeRpc[] = "RecognizeCrossing";
inline constexpr char kCreateSessionRpc[] = "CreateSession";
inline constexpr char kSensorStreamRpc[] = "StreamSensorData";
inline constexpr char kCloseSessionRpc[] = "CloseSession";

struct LoadOptions {
  int robots = 1;
  double duration_s = 60;
  double recognize_hz = 1;  // 0 = no recognition
  double scan_hz = 5;       // 0 = no SLAM session
  double odometry_hz = 10;
  std::string database;               // what the robots recognize against
  std::string world = "office";       // built-in simulator world (or a world file)
  std::string robot_prefix = "load";  // robot ids "load-0", "load-1", ...
  // The sessions' LaserSlamParams.prune_redundant_submaps (the server's default: true); false
  // keeps every scan node, what lifelong mapping is measured against.
  bool prune = true;
};

// One robot's connection: its own clients (so its own channel), as a robot would have.
struct RobotClients {
  std::unique_ptr<client::CrossingClient> crossing;
  std::unique_ptr<client::SlamClient> slam;
};
using ConnectRobot = std::function<RobotClients()>;

struct LoadResult {
  double elapsed_s = 0;      // from the first robot's start to the last one's end
  int64_t recognitions = 0;  // answered
  int64_t recognized = 0;    // of which recognized a crossing
  int sessions_created = 0;
  int sessions_closed = 0;
  int64_t scans_sent = 0;
  int64_t scans_answered = 0;  // processed (a rejection is recorded as a failure)
  // Of which the session skipped for too little motion since its last scan (cheap to answer).
  int64_t scans_skipped = 0;
  int64_t odometry_sent = 0;
};

// Runs the fleet for `options.duration_s` (or until `stop`), recording into `recorder`.
// `queries` are encoded images (at least one when recognize_hz > 0). INVALID_ARGUMENT for bad
// options or an unknown world; call failures are recorded, not returned.
absl::StatusOr<LoadResult> RunLoad(const LoadOptions& options,
                                   const std::vector<std::string>& queries,
                                   const ConnectRobot& connect, LoadRecorder& recorder,
                                   const std::atomic<bool>& stop);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_LOAD_LOAD_GENERATOR_H_
