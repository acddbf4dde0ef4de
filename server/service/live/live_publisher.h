#ifndef WAYMARK_SERVER_SERVICE_LIVE_LIVE_PUBLISHER_H_
#define WAYMARK_SERVER_SERVICE_LIVE_LIVE_PUBLISHER_H_

// The live view's reader of the sessions: one round (Tick) lists the open sessions at
// sessions_seconds, advertises each one's channels and withdraws those of sessions that closed or
// were deleted, takes what the hub's slots hold (live_hub.h) and turns it into messages for the
// channels someone subscribes to, and renders grids and trajectories at their bounded rates
// (live_options.h). Runs on the live server's publisher thread only.
//
// Channels of an open session <id> (docs/live-view.md):
//   /sessions/<id>/pose           foxglove.PoseInFrame
//   /sessions/<id>/scan           foxglove.LaserScan       (laser)
//   /sessions/<id>/grid           foxglove.Grid            (laser)
//   /sessions/<id>/trajectory     foxglove.PosesInFrame
//   /sessions/<id>/loop_closures  waymark.LoopClosures     (laser)
//   /sessions/<id>/confidence     waymark.Confidence
//   /sessions/<id>/vo             waymark.VisualFrame      (visual)
// and, server-wide, /sessions (waymark.Sessions) and /recognitions (waymark.Recognition).

#include <atomic>
#include <chrono>
#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "server/service/live/folder.h"
#include "server/service/live/live_hub.h"
#include "server/service/live/live_options.h"
#include "server/service/live/live_state.h"
#include "server/service/slam/slam_registry.h"

namespace waymark::service::live {

class LivePublisher {
 public:
  using Clock = std::chrono::steady_clock;

  // None is owned; all must outlive this.
  LivePublisher(SlamRegistry* slam, LiveHub* hub, LiveState* state, const LiveOptions& options);

  void Tick(Clock::time_point now);

  // Time spent reading the sessions (grids and trajectories), for docs/live-view.md.
  // Read from any thread.
  double grid_render_seconds() const { return grid_render_seconds_.load(); }
  uint64_t grids_rendered() const { return grids_rendered_.load(); }

 private:
  struct Session {
    std::string kind;  // "laser" or "visual"
    std::string robot_id;
    std::string name;
    v1::Pose2D laser_pose;
    bool resident = false;
    uint64_t scans_processed = 0;
    std::vector<uint32_t> channels;  // all of them, for Unadvertise
    uint32_t pose = 0, scan = 0, grid = 0, trajectory = 0, loop_closures = 0, confidence = 0,
             vo = 0;
    std::vector<std::string> topics;
    // What the answers said last.
    double stamp = 0;
    uint64_t progress = 0;  // scans_processed of the last answer: the map may have changed
    uint32_t loop_closures_sent = 0;
    // Grid and trajectory polls.
    Clock::time_point next_grid{};
    uint64_t grid_progress = UINT64_MAX;  // `progress` the last grid was rendered at
    double grid_resolution = 0;
    bool grid_refused = false;  // FAILED_PRECONDITION: this session has no grid (said once)
    Clock::time_point next_trajectory{};
    uint64_t trajectory_progress = UINT64_MAX;
  };

  void ListSessions(Clock::time_point now);
  void OpenSession(const v1::Session& described);
  void PublishAnswers();
  void PollGrid(const std::string& id, Session& session, Clock::time_point now);
  void PollTrajectory(const std::string& id, Session& session, Clock::time_point now);
  void PublishSessionList(double stamp);
  void PublishRecognitions();

  SlamRegistry* const slam_;
  LiveHub* const hub_;
  LiveState* const state_;
  const LiveOptions options_;
  std::map<std::string, Session> sessions_;
  uint32_t sessions_channel_ = 0;
  uint32_t recognitions_channel_ = 0;
  Clock::time_point next_list_{};
  std::string last_list_error_;
  std::atomic<double> grid_render_seconds_{0};
  std::atomic<uint64_t> grids_rendered_{0};
};

}  // namespace waymark::service::live

#endif  // WAYMARK_SERVER_SERVICE_LIVE_LIVE_PUBLISHER_H_
