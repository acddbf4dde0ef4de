// MapStore on SQLite: one connection behind a mutex, one transaction per mutating call. What is
// not SQL (checks, row reading, messages, which trajectory anchors the map frame) is shared with
// the PostgreSQL store (map_records.h).

#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "storage/map_records.h"
#include "storage/map_store.h"
#include "storage/migrations.h"
#include "storage/slam_records.h"
#include "storage/sqlite.h"
#include "storage/status_macros.h"
#include "storage/store_util.h"
#include "storage/stored_row.h"

namespace waymark::storage {
namespace {

using sqlite::Connection;
using sqlite::Statement;
using sqlite::StepResult;
using sqlite::Transaction;
using sqlite::UniqueViolation;

class SqliteMapStore final : public MapStore {
 public:
  explicit SqliteMapStore(Connection connection) : connection_(std::move(connection)) {}

  absl::StatusOr<MapRecord> CreateMap(const std::string& name) override {
    RETURN_IF_ERROR(CheckMapName(name));
    std::lock_guard<std::mutex> lock(mutex_);
    MapRecord map;
    map.name = name;
    map.created_at = map.updated_at = NowSeconds();
    ASSIGN_OR_RETURN(Statement insert,
                     connection_.Prepare("INSERT INTO slam_map (name, created_at, updated_at, "
                                         "revision) VALUES (?, ?, ?, 0)"));
    RETURN_IF_ERROR(insert.BindText(1, map.name));
    RETURN_IF_ERROR(insert.BindDouble(2, map.created_at));
    RETURN_IF_ERROR(insert.BindDouble(3, map.updated_at));
    absl::Status run = insert.Run(UniqueViolation::kAlreadyExists);
    if (absl::IsAlreadyExists(run)) return MapAlreadyExists(name);
    RETURN_IF_ERROR(run);
    return map;
  }

  absl::StatusOr<MapRecord> GetMap(const std::string& name) override {
    RETURN_IF_ERROR(CheckMapName(name));
    std::lock_guard<std::mutex> lock(mutex_);
    int64_t id = 0;
    return GetMapLocked(name, &id);
  }

  absl::StatusOr<std::vector<MapRecord>> ListMaps() override {
    std::lock_guard<std::mutex> lock(mutex_);
    // Both reads in one transaction, so that the trajectories are those of the maps listed.
    ASSIGN_OR_RETURN(Transaction txn, Transaction::Begin(connection_));
    ASSIGN_OR_RETURN(Statement select,
                     connection_.Prepare(absl::StrCat("SELECT ", kMapColumns,
                                                      " FROM slam_map m ORDER BY m.name")));
    std::vector<MapRecord> maps;
    std::map<int64_t, size_t> index;
    while (true) {
      ASSIGN_OR_RETURN(StepResult step, select.Step());
      if (step == StepResult::kDone) break;
      int64_t id = 0;
      maps.push_back(ReadMapRow(SqliteRow(select), &id));
      index[id] = maps.size() - 1;
    }
    ASSIGN_OR_RETURN(Statement trajectories, connection_.Prepare(SelectMapTrajectories("")));
    while (true) {
      ASSIGN_OR_RETURN(StepResult step, trajectories.Step());
      if (step == StepResult::kDone) break;
      int64_t map_id = 0;
      ASSIGN_OR_RETURN(MapTrajectoryRecord trajectory,
                       ReadMapTrajectoryRow(SqliteRow(trajectories), &map_id));
      if (auto it = index.find(map_id); it != index.end()) {
        maps[it->second].trajectories.push_back(std::move(trajectory));
      }
    }
    RETURN_IF_ERROR(txn.Commit());
    return maps;
  }

  absl::StatusOr<MapRecord> AddTrajectory(const std::string& map,
                                          const std::string& session_id) override {
    RETURN_IF_ERROR(CheckMapName(map));
    std::lock_guard<std::mutex> lock(mutex_);
    ASSIGN_OR_RETURN(Transaction txn, Transaction::Begin(connection_));
    int64_t id = 0;
    ASSIGN_OR_RETURN(MapRecord record, GetMapLocked(map, &id));
    RETURN_IF_ERROR(SessionExistsLocked(session_id));
    ASSIGN_OR_RETURN(Statement member,
                     connection_.Prepare("SELECT m.name FROM slam_map_trajectory t JOIN slam_map m "
                                         "ON m.id = t.map_id WHERE t.session_id = ?"));
    RETURN_IF_ERROR(member.BindText(1, session_id));
    ASSIGN_OR_RETURN(StepResult in_map, member.Step());
    if (in_map == StepResult::kRow) return SessionAlreadyInMap(session_id, member.ColumnText(0));
    const int64_t ordinal =
        record.trajectories.empty() ? 1 : record.trajectories.back().ordinal + 1;
    ASSIGN_OR_RETURN(Statement insert,
                     connection_.Prepare("INSERT INTO slam_map_trajectory (map_id, session_id, "
                                         "ordinal, joined_at) VALUES (?, ?, ?, ?)"));
    RETURN_IF_ERROR(insert.BindInt64(1, id));
    RETURN_IF_ERROR(insert.BindText(2, session_id));
    RETURN_IF_ERROR(insert.BindInt64(3, ordinal));
    RETURN_IF_ERROR(insert.BindDouble(4, NowSeconds()));
    absl::Status run = insert.Run(UniqueViolation::kAlreadyExists);
    if (absl::IsAlreadyExists(run)) return SessionAlreadyInMap(session_id, map);
    RETURN_IF_ERROR(run);
    ASSIGN_OR_RETURN(MapRecord changed, ChangedLocked(map, id));
    RETURN_IF_ERROR(txn.Commit());
    return changed;
  }

  absl::StatusOr<MapRecord> TieTrajectory(const std::string& map, const std::string& session_id,
                                          const MapTie& tie, const std::string& follow) override {
    RETURN_IF_ERROR(CheckMapName(map));
    RETURN_IF_ERROR(CheckMapTie(tie));
    std::lock_guard<std::mutex> lock(mutex_);
    ASSIGN_OR_RETURN(Transaction txn, Transaction::Begin(connection_));
    int64_t id = 0;
    ASSIGN_OR_RETURN(MapRecord record, GetMapLocked(map, &id));
    (void)record;
    RETURN_IF_ERROR(SetTieLocked(id, session_id, tie, follow));
    if (connection_.Changes() == 0) return MapTrajectoryNotFound(map, session_id);
    ASSIGN_OR_RETURN(MapRecord changed, ChangedLocked(map, id));
    RETURN_IF_ERROR(txn.Commit());
    return changed;
  }

  absl::StatusOr<MapRecord> RemoveTrajectory(const std::string& map,
                                             const std::string& session_id) override {
    RETURN_IF_ERROR(CheckMapName(map));
    std::lock_guard<std::mutex> lock(mutex_);
    ASSIGN_OR_RETURN(Transaction txn, Transaction::Begin(connection_));
    int64_t id = 0;
    ASSIGN_OR_RETURN(MapRecord record, GetMapLocked(map, &id));
    (void)record;
    ASSIGN_OR_RETURN(Statement remove,
                     connection_.Prepare(
                         "DELETE FROM slam_map_trajectory WHERE map_id = ? AND session_id = ?"));
    RETURN_IF_ERROR(remove.BindInt64(1, id));
    RETURN_IF_ERROR(remove.BindText(2, session_id));
    RETURN_IF_ERROR(remove.Run());
    ASSIGN_OR_RETURN(MapRecord changed, ChangedLocked(map, id));
    RETURN_IF_ERROR(txn.Commit());
    return changed;
  }

  absl::StatusOr<MapRecord> DeleteMap(const std::string& name) override {
    RETURN_IF_ERROR(CheckMapName(name));
    std::lock_guard<std::mutex> lock(mutex_);
    ASSIGN_OR_RETURN(Transaction txn, Transaction::Begin(connection_));
    int64_t id = 0;
    ASSIGN_OR_RETURN(MapRecord record, GetMapLocked(name, &id));
    // ON DELETE CASCADE removes the trajectory rows; the sessions stay.
    ASSIGN_OR_RETURN(Statement remove, connection_.Prepare("DELETE FROM slam_map WHERE id = ?"));
    RETURN_IF_ERROR(remove.BindInt64(1, id));
    RETURN_IF_ERROR(remove.Run());
    RETURN_IF_ERROR(txn.Commit());
    return record;
  }

  absl::StatusOr<SlamLease> AcquireMapLease(const std::string& map, const std::string& owner,
                                            const std::string& address,
                                            double ttl_seconds) override {
    RETURN_IF_ERROR(CheckMapName(map));
    RETURN_IF_ERROR(CheckLeaseRequest(owner, ttl_seconds));
    std::lock_guard<std::mutex> lock(mutex_);
    // The write transaction holds the file's write lock from the read to the commit.
    ASSIGN_OR_RETURN(Transaction txn, Transaction::Begin(connection_));
    int64_t id = 0;
    ASSIGN_OR_RETURN(MapRecord record, GetMapLocked(map, &id));
    const SlamLease lease = LeaseAfter(record.lease, owner, address, ttl_seconds, NowSeconds());
    if (lease.owner != owner) return lease;  // held by another: nothing to write
    ASSIGN_OR_RETURN(Statement update,
                     connection_.Prepare("UPDATE slam_map SET lease_owner = ?, lease_address = ?, "
                                         "lease_expires_at = ? WHERE id = ?"));
    RETURN_IF_ERROR(update.BindText(1, lease.owner));
    RETURN_IF_ERROR(update.BindText(2, lease.address));
    RETURN_IF_ERROR(update.BindDouble(3, lease.expires_at));
    RETURN_IF_ERROR(update.BindInt64(4, id));
    RETURN_IF_ERROR(update.Run());
    RETURN_IF_ERROR(txn.Commit());
    return lease;
  }

  absl::Status ReleaseMapLease(const std::string& map, const std::string& owner) override {
    RETURN_IF_ERROR(CheckMapName(map));
    std::lock_guard<std::mutex> lock(mutex_);
    ASSIGN_OR_RETURN(Statement update,
                     connection_.Prepare(absl::StrCat("UPDATE slam_map SET ", kClearSlamLease,
                                                      " WHERE name = ? AND lease_owner = ?")));
    RETURN_IF_ERROR(update.BindText(1, map));
    RETURN_IF_ERROR(update.BindText(2, owner));
    return update.Run();
  }

  absl::StatusOr<int64_t> PublishTrajectoryFeed(const std::string& session_id,
                                                const TrajectoryFeedUpdate& update) override {
    std::lock_guard<std::mutex> lock(mutex_);
    ASSIGN_OR_RETURN(Transaction txn, Transaction::Begin(connection_));
    RETURN_IF_ERROR(SessionExistsLocked(session_id));
    if (update.replace) {
      ASSIGN_OR_RETURN(Statement all,
                       connection_.Prepare("DELETE FROM slam_map_feed_node WHERE session_id = ?"));
      RETURN_IF_ERROR(all.BindText(1, session_id));
      RETURN_IF_ERROR(all.Run());
    }
    ASSIGN_OR_RETURN(Statement drop,
                     connection_.Prepare("DELETE FROM slam_map_feed_node WHERE session_id = ? "
                                         "AND scan = ?"));
    for (const int64_t scan : update.dropped) {
      drop.Reset();
      RETURN_IF_ERROR(drop.BindText(1, session_id));
      RETURN_IF_ERROR(drop.BindInt64(2, scan));
      RETURN_IF_ERROR(drop.Run());
    }
    ASSIGN_OR_RETURN(Statement add,
                     connection_.Prepare("INSERT OR REPLACE INTO slam_map_feed_node (session_id, "
                                         "scan, points) VALUES (?, ?, ?)"));
    for (const FeedNodePoints& node : update.added) {
      add.Reset();
      RETURN_IF_ERROR(add.BindText(1, session_id));
      RETURN_IF_ERROR(add.BindInt64(2, node.scan));
      RETURN_IF_ERROR(add.BindBlob(3, node.points.data(), node.points.size()));
      RETURN_IF_ERROR(add.Run());
    }
    ASSIGN_OR_RETURN(Statement upsert,
                     connection_.Prepare(
                         "INSERT INTO slam_map_feed (session_id, version, scans_processed, "
                         "updated_at, poses) VALUES (?, 1, ?, ?, ?) ON CONFLICT (session_id) DO "
                         "UPDATE SET version = slam_map_feed.version + 1, scans_processed = "
                         "excluded.scans_processed, updated_at = excluded.updated_at, poses = "
                         "excluded.poses RETURNING version"));
    RETURN_IF_ERROR(upsert.BindText(1, session_id));
    RETURN_IF_ERROR(upsert.BindInt64(2, update.scans_processed));
    RETURN_IF_ERROR(upsert.BindDouble(3, NowSeconds()));
    RETURN_IF_ERROR(upsert.BindBlob(4, update.poses.data(), update.poses.size()));
    ASSIGN_OR_RETURN(StepResult row, upsert.Step());
    if (row != StepResult::kRow) return absl::InternalError("publishing a feed gave no version");
    const int64_t version = upsert.ColumnInt64(0);
    upsert.Reset();
    RETURN_IF_ERROR(txn.Commit());
    return version;
  }

  absl::StatusOr<std::optional<TrajectoryFeed>> ReadTrajectoryFeed(const std::string& session_id,
                                                                   int64_t after_version,
                                                                   int64_t after_scan) override {
    std::lock_guard<std::mutex> lock(mutex_);
    // Both reads in one transaction: the points are those of the poses read.
    ASSIGN_OR_RETURN(Transaction txn, Transaction::Begin(connection_));
    ASSIGN_OR_RETURN(Statement select,
                     connection_.Prepare("SELECT version, scans_processed, poses FROM "
                                         "slam_map_feed WHERE session_id = ? AND version > ?"));
    RETURN_IF_ERROR(select.BindText(1, session_id));
    RETURN_IF_ERROR(select.BindInt64(2, after_version));
    ASSIGN_OR_RETURN(StepResult step, select.Step());
    if (step == StepResult::kDone) return std::optional<TrajectoryFeed>();
    TrajectoryFeed feed;
    feed.version = select.ColumnInt64(0);
    feed.scans_processed = select.ColumnInt64(1);
    feed.poses = std::string(select.ColumnBlobView(2));
    ASSIGN_OR_RETURN(Statement points,
                     connection_.Prepare("SELECT scan, points FROM slam_map_feed_node WHERE "
                                         "session_id = ? AND scan > ? ORDER BY scan"));
    RETURN_IF_ERROR(points.BindText(1, session_id));
    RETURN_IF_ERROR(points.BindInt64(2, after_scan));
    while (true) {
      ASSIGN_OR_RETURN(StepResult row, points.Step());
      if (row == StepResult::kDone) break;
      feed.points.push_back(
          FeedNodePoints{points.ColumnInt64(0), std::string(points.ColumnBlobView(1))});
    }
    return std::optional<TrajectoryFeed>(std::move(feed));
  }

 private:
  // NOT_FOUND unless the session exists.
  absl::Status SessionExistsLocked(const std::string& session_id) {
    ASSIGN_OR_RETURN(Statement session,
                     connection_.Prepare("SELECT 1 FROM slam_session WHERE id = ?"));
    RETURN_IF_ERROR(session.BindText(1, session_id));
    ASSIGN_OR_RETURN(StepResult found, session.Step());
    if (found == StepResult::kDone) return MapSessionNotFound(session_id);
    return absl::OkStatus();
  }

  absl::StatusOr<MapRecord> GetMapLocked(const std::string& name, int64_t* id) {
    ASSIGN_OR_RETURN(Statement select,
                     connection_.Prepare(absl::StrCat("SELECT ", kMapColumns,
                                                      " FROM slam_map m WHERE m.name = ?")));
    RETURN_IF_ERROR(select.BindText(1, name));
    ASSIGN_OR_RETURN(StepResult step, select.Step());
    if (step == StepResult::kDone) return MapNotFound(name);
    MapRecord map = ReadMapRow(SqliteRow(select), id);
    ASSIGN_OR_RETURN(Statement trajectories,
                     connection_.Prepare(SelectMapTrajectories("WHERE t.map_id = ?")));
    RETURN_IF_ERROR(trajectories.BindInt64(1, *id));
    while (true) {
      ASSIGN_OR_RETURN(StepResult row, trajectories.Step());
      if (row == StepResult::kDone) break;
      int64_t map_id = 0;
      ASSIGN_OR_RETURN(MapTrajectoryRecord trajectory,
                       ReadMapTrajectoryRow(SqliteRow(trajectories), &map_id));
      map.trajectories.push_back(std::move(trajectory));
    }
    return map;
  }

  absl::Status SetTieLocked(int64_t id, const std::string& session_id, const MapTie& tie,
                            const std::string& follow) {
    ASSIGN_OR_RETURN(Statement update,
                     connection_.Prepare("UPDATE slam_map_trajectory SET tie_x = ?, tie_y = ?, "
                                         "tie_theta = ?, follow = ? "
                                         "WHERE map_id = ? AND session_id = ?"));
    RETURN_IF_ERROR(update.BindDouble(1, tie.x));
    RETURN_IF_ERROR(update.BindDouble(2, tie.y));
    RETURN_IF_ERROR(update.BindDouble(3, tie.theta));
    if (follow.empty()) {
      RETURN_IF_ERROR(update.BindNull(4));
    } else {
      RETURN_IF_ERROR(update.BindBlob(4, follow.data(), follow.size()));
    }
    RETURN_IF_ERROR(update.BindInt64(5, id));
    RETURN_IF_ERROR(update.BindText(6, session_id));
    return update.Run();
  }

  // After a change of map `id`: anchors the map frame on its oldest trajectory when none is tied
  // in, counts the revision and returns the map as it now stands.
  absl::StatusOr<MapRecord> ChangedLocked(const std::string& name, int64_t id) {
    ASSIGN_OR_RETURN(MapRecord map, GetMapLocked(name, &id));
    if (std::optional<std::string> anchor = TrajectoryToAnchor(map); anchor.has_value()) {
      RETURN_IF_ERROR(SetTieLocked(id, *anchor, MapTie{}, ""));
    }
    ASSIGN_OR_RETURN(Statement bump,
                     connection_.Prepare("UPDATE slam_map SET revision = revision + 1, "
                                         "updated_at = ? WHERE id = ?"));
    RETURN_IF_ERROR(bump.BindDouble(1, NowSeconds()));
    RETURN_IF_ERROR(bump.BindInt64(2, id));
    RETURN_IF_ERROR(bump.Run());
    return GetMapLocked(name, &id);
  }

  std::mutex mutex_;
  Connection connection_;
};

}  // namespace

absl::StatusOr<std::unique_ptr<MapStore>> OpenSqliteMapStore(const std::string& path) {
  ASSIGN_OR_RETURN(Connection connection, OpenMigratedDatabase(path));
  return std::unique_ptr<MapStore>(new SqliteMapStore(std::move(connection)));
}

}  // namespace waymark::storage
