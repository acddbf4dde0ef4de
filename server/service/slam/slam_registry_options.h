#ifndef WAYMARK_SERVER_SERVICE_SLAM_SLAM_REGISTRY_OPTIONS_H_
#define WAYMARK_SERVER_SERVICE_SLAM_SLAM_REGISTRY_OPTIONS_H_

// SlamRegistry's options and limits (slam_registry.h), in a header of their own so that the
// registry's parts can read them without the facade.

#include <chrono>
#include <cstddef>
#include <functional>
#include <string>

#include "server/service/slam/folder.h"
#include "server/service/slam/session_leases.h"

namespace waymark::service {

struct SlamRegistryOptions {
  int queue_capacity = 64;        // messages waiting per session
  int workers = 0;                // 0 = std::thread::hardware_concurrency()
  double checkpoint_seconds = 30;  // 0 = no time-based checkpoints
  int checkpoint_scans = 500;     // 0 = no count-based checkpoints
  int max_sessions = 64;          // open sessions per server
  int max_batch = 8;              // messages of one session per turn of a worker
  // Store every accepted message before processing it (see Journal in slam_registry.h).
  bool journal = true;
  // Checkpoint once the journal since the last checkpoint holds this many bytes (camera frames:
  // 30 s of 30 Hz RGB-D is several hundred MB), which bounds the replay after a crash.
  size_t checkpoint_journal_bytes = size_t{64} << 20;
  // Decoded frames waiting per visual session (640x480 RGB-D: 1.5 MB a frame).
  size_t max_queued_frame_bytes = size_t{64} << 20;
  // A stream opened while the session has one (the robot reconnected) waits this long for the
  // old stream's accepted messages to be answered, then takes the session over; UNAVAILABLE
  // after it.
  std::chrono::milliseconds stream_handover_wait{10000};
  // Maps shared by robots: find a joined robot in its map from its scans and tie it in
  // (map_tie_worker.h). False: only CreateSessionRequest.initial_map_pose ties a robot in.
  bool map_tie = true;
  // After the tie, match every robot but the map frame's again against the others in local
  // windows (laser_slam::TrajectoryFollow): its origin becomes piecewise. False: one origin.
  bool map_follow = true;
  // The map's grid, segment map and node_origins from one pose graph over all its trajectories
  // (MapRegistry::set_map_graph); false: each trajectory placed on its own.
  bool map_graph = true;
  // How far a followed robot is looked for (laser_slam::FollowOptions). Uncertainty (the
  // default): at least the narrow windows, and as far as the robot's own and the map's chain
  // uncertainty reach, up to 30 m. Narrow (laser_slam::NarrowFollowWindows): at most 2 m and
  // 0.4 rad. Wide (laser_slam::WideFollowWindows: the map's drift by its path length, 30 m
  // caps): a robot in the wrong room where the building has look-alike rooms.
  enum class FollowWindows { kNarrow, kWide, kUncertainty };
  FollowWindows map_follow_windows = FollowWindows::kUncertainty;
  // On a fleet: a robot's nodes are published for its map's owner at most this often (s), so that
  // the owner ties and follows it between its checkpoints (trajectory_feed.h); 0: the owner reads
  // the robot's checkpoints only.
  double map_feed_seconds = 1.0;
  // A tie needs the kept unique matches to outvote the ones disagreeing with it
  // (laser_slam::TieOptions::outvote_disagreements); false: the first agreeing pair ties.
  bool map_tie_outvote = true;
  // A tie is kept only when the map's self-check with the robot placed there finds no new
  // contradicting area (laser_slam::TieKeepsTheMapConsistent).
  bool map_tie_verify = true;
  // Several servers on one database (PostgreSQL): each session is served by the one holding its
  // lease (session_leases.h). Off (owner empty) with one server per database.
  SessionLeaseOptions lease;
  // Test hook: runs on the worker thread before each message of `session_id` is processed.
  std::function<void(const std::string& session_id)> before_process;
};

inline constexpr int kMaxRobotIdLength = 128;
inline constexpr int kMaxSessionNameLength = 256;

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_SLAM_SLAM_REGISTRY_OPTIONS_H_
