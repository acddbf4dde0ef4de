#include "client/sessions/session_grid.h"

#include <fmt/format.h>

namespace waymark::cli {

absl::StatusOr<SessionGrid> FetchSessionGrid(client::SlamClient& client,
                                             const std::string& session_id,
                                             std::optional<double> resolution) {
  absl::StatusOr<v1::OccupancyGrid> grid = client.GetOccupancyGrid(session_id, resolution);
  SessionGrid result;
  if (absl::IsFailedPrecondition(grid.status())) {
    result.missing = fmt::format("no occupancy grid for session {}: {}", session_id,
                                 std::string(grid.status().message()));
  } else if (absl::IsUnimplemented(grid.status())) {
    result.missing =
        "no occupancy grid: the server does not serve them (GetOccupancyGrid: UNIMPLEMENTED; it "
        "is older than this client)";
  } else if (!grid.ok()) {
    return grid.status();
  } else if (grid->width() == 0 || grid->height() == 0) {
    result.missing =
        fmt::format("no occupancy grid for session {}: it is empty (no scans)", session_id);
  } else {
    result.grid = *std::move(grid);
  }
  return result;
}

}  // namespace waymark::cli
