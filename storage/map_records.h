#ifndef WAYMARK_STORAGE_MAP_RECORDS_H_
#define WAYMARK_STORAGE_MAP_RECORDS_H_

// What the SQLite and PostgreSQL MapStores share (as slam_records.h for sessions): the checks of
// what a caller asks to store, the columns they select and how rows become records, and the error
// messages, written once so that both backends accept, refuse and report the same things.

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "storage/map_store.h"
#include "storage/stored_row.h"

namespace waymark::storage {

inline constexpr size_t kMaxMapNameLength = 64;

// INVALID_ARGUMENT unless `name` is 1-64 characters of A-Z a-z 0-9 '.' '_' '-' starting with a
// letter or a digit (names become file names: `waymark map grid NAME` writes NAME.pgm). The
// message does not echo a name it refuses (it may be any bytes), only what is wrong with it.
absl::Status CheckMapName(absl::string_view name);

// INVALID_ARGUMENT for a tie that is not finite.
absl::Status CheckMapTie(const MapTie& tie);

absl::Status MapNotFound(absl::string_view name);
absl::Status MapAlreadyExists(absl::string_view name);
// A session in a map already (it may be in one only).
absl::Status SessionAlreadyInMap(absl::string_view session_id, absl::string_view map);
absl::Status MapSessionNotFound(absl::string_view session_id);
absl::Status MapTrajectoryNotFound(absl::string_view map, absl::string_view session_id);

// slam_map's columns (alias m) in the order ReadMapRow reads: id, then the record's fields.
inline constexpr absl::string_view kMapColumns =
    "m.id, m.name, m.created_at, m.updated_at, m.revision, m.lease_owner, m.lease_address, "
    "m.lease_expires_at";
// Sets `id` to the row's map id.
MapRecord ReadMapRow(const StoredRow& row, int64_t* id);

// A SELECT of trajectories (alias t) joined with their sessions (alias s), in the column order
// ReadMapTrajectoryRow reads (map_id first); `where` (the backend's placeholders) follows the
// join; rows come in map and join order.
std::string SelectMapTrajectories(absl::string_view where);
// Sets `map_id` to the row's map. DATA_LOSS for a tie stored in part, or a state neither open
// nor closed.
absl::StatusOr<MapTrajectoryRecord> ReadMapTrajectoryRow(const StoredRow& row, int64_t* map_id);

// The oldest trajectory to tie in at the origin when none of `map`'s is tied in (RemoveTrajectory,
// AddTrajectory's first one); none when one is tied in or the map has none.
std::optional<std::string> TrajectoryToAnchor(const MapRecord& map);

}  // namespace waymark::storage

#endif  // WAYMARK_STORAGE_MAP_RECORDS_H_
