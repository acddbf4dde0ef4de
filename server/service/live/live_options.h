#ifndef WAYMARK_SERVER_SERVICE_LIVE_LIVE_OPTIONS_H_
#define WAYMARK_SERVER_SERVICE_LIVE_LIVE_OPTIONS_H_

// The live view's settings (waymark-server --live, docs/live-view.md). The rates bound what the
// view costs the robots whatever the viewers do: it reads the sessions at these rates, never per
// viewer.

#include <cstddef>
#include <string>

#include "absl/status/statusor.h"
#include "server/service/live/folder.h"

namespace waymark::service::live {

struct LiveOptions {
  std::string host = "127.0.0.1";
  int port = 0;  // 0 picks a free one
  // The publisher's round: poses, scans, confidence, VO frames and loop closures go out at most
  // once per round per channel (the newest; older answers of the round are skipped).
  double tick_seconds = 0.1;
  // Open sessions are listed this often: channels are advertised and withdrawn on that beat.
  double sessions_seconds = 1.0;
  // Occupancy grids: rendered only for a session someone subscribes to, after its map changed, at
  // most once per grid_seconds, and never more than grid_duty of the time (a render holds the
  // session's engine as GetOccupancyGrid does: the next one waits duration / grid_duty).
  double grid_seconds = 1.0;
  double grid_duty = 0.1;
  double grid_resolution = 0.1;            // m; doubled (up to 1 m) for maps beyond max_grid_cells
  size_t max_grid_cells = 1'000'000;
  double trajectory_seconds = 1.0;         // trajectories: as the grids, same rate
  size_t max_trajectory_poses = 2000;      // every k-th pose beyond
  // Viewers.
  int max_viewers = 16;                    // more are refused (HTTP 503)
  int socket_send_buffer = 256 * 1024;     // SO_SNDBUF of a viewer's socket (bytes)
  double stall_seconds = 10;               // a viewer that takes nothing for this long is dropped
  size_t scan_ring = 64;                   // admitted scans kept per session until answered
};

// "PORT", ":PORT" or "HOST:PORT" (IPv4 or a name) into options.host/port; a bare port listens on
// the loopback. INVALID_ARGUMENT naming the flag otherwise.
absl::Status ParseLiveAddress(const std::string& address, LiveOptions* options);

}  // namespace waymark::service::live

#endif  // WAYMARK_SERVER_SERVICE_LIVE_LIVE_OPTIONS_H_
