#ifndef WAYMARK_CLIENT_SESSIONS_SESSION_GRID_H_
#define WAYMARK_CLIENT_SESSIONS_SESSION_GRID_H_

// A session's occupancy grid for the commands that write it beside the segment map (`slam map`,
// `slam replay`): the grid, or one line saying why the server has none to give. Not every session
// has a grid: one with loop closure off keeps no scans to draw it from.

#include <optional>
#include <string>

#include "absl/status/statusor.h"
#include "client/lib/slam_client.h"
#include "waymark/v1/slam.pb.h"

namespace waymark::cli {

struct SessionGrid {
  std::optional<v1::OccupancyGrid> grid;
  std::string missing;  // why there is no grid (set exactly when `grid` is not)
};

// GetOccupancyGrid for `session_id`. The server answering FAILED_PRECONDITION (no scans kept) or
// UNIMPLEMENTED (a server older than the RPC), and an empty grid, are a SessionGrid without a grid
// and the reason; any other error is returned.
absl::StatusOr<SessionGrid> FetchSessionGrid(client::SlamClient& client,
                                             const std::string& session_id,
                                             std::optional<double> resolution);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_SESSIONS_SESSION_GRID_H_
