#include "storage/map_records.h"

#include <cmath>

#include "absl/strings/str_cat.h"
#include "storage/slam_records.h"
#include "storage/store_util.h"

namespace waymark::storage {
namespace {

bool IsNameCharacter(char c) {
  return (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == '.' ||
         c == '_' || c == '-';
}

}  // namespace

absl::Status CheckMapName(absl::string_view name) {
  constexpr absl::string_view kRule =
      "a map name is 1-64 characters of A-Z a-z 0-9 '.' '_' '-', starting with a letter or a "
      "digit";
  if (name.empty()) return absl::InvalidArgumentError(absl::StrCat("map name is empty: ", kRule));
  if (name.size() > kMaxMapNameLength) {
    return absl::InvalidArgumentError(
        absl::StrCat("map name is ", name.size(), " bytes long: ", kRule));
  }
  for (size_t i = 0; i < name.size(); ++i) {
    if (!IsNameCharacter(name[i])) {
      return absl::InvalidArgumentError(
          absl::StrCat("map name has a character outside the allowed set at byte ", i, ": ", kRule));
    }
  }
  if (name[0] == '.' || name[0] == '_' || name[0] == '-') {
    return absl::InvalidArgumentError(absl::StrCat("map name starts with '", name.substr(0, 1),
                                                   "': ", kRule));
  }
  return absl::OkStatus();
}

absl::Status CheckMapTie(const MapTie& tie) {
  if (!std::isfinite(tie.x) || !std::isfinite(tie.y) || !std::isfinite(tie.theta)) {
    return absl::InvalidArgumentError("a trajectory's tie into its map must be finite");
  }
  return absl::OkStatus();
}

absl::Status MapNotFound(absl::string_view name) {
  return absl::NotFoundError(absl::StrCat("map ", Quoted(name), " not found"));
}

absl::Status MapAlreadyExists(absl::string_view name) {
  return absl::AlreadyExistsError(absl::StrCat("map ", Quoted(name), " already exists"));
}

absl::Status SessionAlreadyInMap(absl::string_view session_id, absl::string_view map) {
  return absl::AlreadyExistsError(absl::StrCat("SLAM session ", Quoted(session_id),
                                               " is already in map ", Quoted(map),
                                               "; a session is in one map at most"));
}

absl::Status MapSessionNotFound(absl::string_view session_id) {
  return SlamSessionNotFound(session_id);
}

absl::Status MapTrajectoryNotFound(absl::string_view map, absl::string_view session_id) {
  return absl::NotFoundError(absl::StrCat("map ", Quoted(map), " has no trajectory of session ",
                                          Quoted(session_id)));
}

MapRecord ReadMapRow(const StoredRow& row, int64_t* id) {
  *id = row.Int64(0);
  MapRecord map;
  map.name = row.Text(1);
  map.created_at = row.Double(2);
  map.updated_at = row.Double(3);
  map.revision = row.Int64(4);
  // NULL (never leased, or given up) reads as nobody's.
  map.lease = SlamLease{row.Text(5), row.Text(6), row.OptionalDouble(7).value_or(0.0)};
  return map;
}

std::string SelectMapTrajectories(absl::string_view where) {
  return absl::StrCat(
      "SELECT t.map_id, t.session_id, t.ordinal, t.joined_at, t.tie_x, t.tie_y, t.tie_theta, "
      "s.robot_id, s.state, s.scans_processed, t.follow "
      "FROM slam_map_trajectory t JOIN slam_session s ON s.id = t.session_id ",
      where, " ORDER BY t.map_id, t.ordinal");
}

absl::StatusOr<MapTrajectoryRecord> ReadMapTrajectoryRow(const StoredRow& row, int64_t* map_id) {
  *map_id = row.Int64(0);
  MapTrajectoryRecord trajectory;
  trajectory.session_id = row.Text(1);
  trajectory.ordinal = row.Int64(2);
  trajectory.joined_at = row.Double(3);
  const int nulls = row.IsNull(4) + row.IsNull(5) + row.IsNull(6);
  if (nulls == 0) {
    trajectory.tie = MapTie{row.Double(4), row.Double(5), row.Double(6)};
  } else if (nulls != 3) {
    return absl::DataLossError(absl::StrCat("the trajectory of session ",
                                            Quoted(trajectory.session_id),
                                            " in its map has a tie stored in part"));
  }
  trajectory.robot_id = row.Text(7);
  const std::string state = row.Text(8);
  if (state == "open") {
    trajectory.session_state = SlamSessionState::kOpen;
  } else if (state == "closed") {
    trajectory.session_state = SlamSessionState::kClosed;
  } else {
    return absl::DataLossError(absl::StrCat("SLAM session ", Quoted(trajectory.session_id),
                                            " has an unknown state ", Quoted(state)));
  }
  trajectory.scans_processed = row.Int64(9);
  trajectory.follow = row.Text(10);
  return trajectory;
}

std::optional<std::string> TrajectoryToAnchor(const MapRecord& map) {
  for (const MapTrajectoryRecord& trajectory : map.trajectories) {
    if (trajectory.tie.has_value()) return std::nullopt;
  }
  if (map.trajectories.empty()) return std::nullopt;
  return map.trajectories.front().session_id;
}

}  // namespace waymark::storage
