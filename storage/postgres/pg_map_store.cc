// MapStore on PostgreSQL (issue 38), the port of sqlite_map_store.cc: this file holds the SQL and
// the transactions; the checks, the reading of rows, which trajectory anchors the map frame and
// the messages are shared with the SQLite store (map_records.h).
//
// Several servers may change one map at once: every change locks the map's row first (FOR
// UPDATE), so that two robots joining at once get ordinals one after the other and only one of
// them can find the map without a tied-in trajectory and define its frame.

#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "storage/map_records.h"
#include "storage/map_store.h"
#include "storage/postgres/pg.h"
#include "storage/postgres/pg_stores.h"
#include "storage/slam_records.h"
#include "storage/status_macros.h"
#include "storage/store_util.h"
#include "storage/stored_row.h"

namespace waymark::storage {
namespace {

using pg::Connection;
using pg::Params;
using pg::Result;
using pg::UniqueViolation;

class PostgresMapStore final : public MapStore {
 public:
  explicit PostgresMapStore(std::shared_ptr<pg::Pool> pool) : pool_(std::move(pool)) {}

  absl::StatusOr<MapRecord> CreateMap(const std::string& name) override {
    RETURN_IF_ERROR(CheckMapName(name));
    MapRecord map;
    map.name = name;
    map.created_at = map.updated_at = NowSeconds();
    absl::Status insert = pool_->Transaction([&](Connection& connection) {
      return connection
          .Execute("INSERT INTO slam_map (name, created_at, updated_at, revision) "
                   "VALUES ($1, $2, $3, 0)",
                   Params().Text(map.name).Double(map.created_at).Double(map.updated_at),
                   UniqueViolation::kAlreadyExists)
          .status();
    });
    if (absl::IsAlreadyExists(insert)) return MapAlreadyExists(name);
    RETURN_IF_ERROR(insert);
    return map;
  }

  absl::StatusOr<MapRecord> GetMap(const std::string& name) override {
    RETURN_IF_ERROR(CheckMapName(name));
    return pool_->Run<MapRecord>([&](Connection& connection) -> absl::StatusOr<MapRecord> {
      int64_t id = 0;
      return ReadMap(connection, name, /*lock=*/false, &id);
    });
  }

  absl::StatusOr<std::vector<MapRecord>> ListMaps() override {
    using Maps = std::vector<MapRecord>;
    // One transaction (REPEATABLE READ is not needed: a trajectory of a map created meanwhile is
    // skipped, one of a map deleted meanwhile has no map to go to).
    return pool_->Transaction<Maps>([&](Connection& connection) -> absl::StatusOr<Maps> {
      // Names in byte order, as SQLite compares them, whatever the database's collation.
      ASSIGN_OR_RETURN(Result rows,
                       connection.Execute(absl::StrCat("SELECT ", kMapColumns,
                                                       " FROM slam_map m ORDER BY m.name "
                                                       "COLLATE \"C\"")));
      Maps maps;
      std::map<int64_t, size_t> index;
      for (int row = 0; row < rows.rows(); ++row) {
        int64_t id = 0;
        maps.push_back(ReadMapRow(PgRow(rows, row), &id));
        index[id] = maps.size() - 1;
      }
      ASSIGN_OR_RETURN(Result trajectories, connection.Execute(SelectMapTrajectories("")));
      for (int row = 0; row < trajectories.rows(); ++row) {
        int64_t map_id = 0;
        ASSIGN_OR_RETURN(MapTrajectoryRecord trajectory,
                         ReadMapTrajectoryRow(PgRow(trajectories, row), &map_id));
        if (auto it = index.find(map_id); it != index.end()) {
          maps[it->second].trajectories.push_back(std::move(trajectory));
        }
      }
      return maps;
    });
  }

  absl::StatusOr<MapRecord> AddTrajectory(const std::string& map,
                                          const std::string& session_id) override {
    RETURN_IF_ERROR(CheckMapName(map));
    return pool_->Transaction<MapRecord>([&](Connection& connection) -> absl::StatusOr<MapRecord> {
      int64_t id = 0;
      ASSIGN_OR_RETURN(MapRecord record, ReadMap(connection, map, /*lock=*/true, &id));
      // FOR SHARE: the session cannot be deleted before the trajectory row is in.
      ASSIGN_OR_RETURN(Result session,
                       connection.Execute("SELECT 1 FROM slam_session WHERE id = $1 FOR SHARE",
                                          Params().Text(session_id)));
      if (session.rows() == 0) return MapSessionNotFound(session_id);
      ASSIGN_OR_RETURN(Result member,
                       connection.Execute("SELECT m.name FROM slam_map_trajectory t "
                                          "JOIN slam_map m ON m.id = t.map_id "
                                          "WHERE t.session_id = $1",
                                          Params().Text(session_id)));
      if (member.rows() > 0) return SessionAlreadyInMap(session_id, member.Text(0, 0));
      const int64_t ordinal =
          record.trajectories.empty() ? 1 : record.trajectories.back().ordinal + 1;
      absl::Status insert =
          connection
              .Execute("INSERT INTO slam_map_trajectory (map_id, session_id, ordinal, joined_at) "
                       "VALUES ($1, $2, $3, $4)",
                       Params().Int64(id).Text(session_id).Int64(ordinal).Double(NowSeconds()),
                       UniqueViolation::kAlreadyExists)
              .status();
      if (absl::IsAlreadyExists(insert)) return SessionAlreadyInMap(session_id, map);
      RETURN_IF_ERROR(insert);
      return Changed(connection, map, id);
    });
  }

  absl::StatusOr<MapRecord> TieTrajectory(const std::string& map, const std::string& session_id,
                                          const MapTie& tie, const std::string& follow) override {
    RETURN_IF_ERROR(CheckMapName(map));
    RETURN_IF_ERROR(CheckMapTie(tie));
    return pool_->Transaction<MapRecord>([&](Connection& connection) -> absl::StatusOr<MapRecord> {
      int64_t id = 0;
      RETURN_IF_ERROR(ReadMap(connection, map, /*lock=*/true, &id).status());
      ASSIGN_OR_RETURN(int64_t changed, SetTie(connection, id, session_id, tie, follow));
      if (changed == 0) return MapTrajectoryNotFound(map, session_id);
      return Changed(connection, map, id);
    });
  }

  absl::StatusOr<MapRecord> RemoveTrajectory(const std::string& map,
                                             const std::string& session_id) override {
    RETURN_IF_ERROR(CheckMapName(map));
    return pool_->Transaction<MapRecord>([&](Connection& connection) -> absl::StatusOr<MapRecord> {
      int64_t id = 0;
      RETURN_IF_ERROR(ReadMap(connection, map, /*lock=*/true, &id).status());
      RETURN_IF_ERROR(connection
                          .Execute("DELETE FROM slam_map_trajectory "
                                   "WHERE map_id = $1 AND session_id = $2",
                                   Params().Int64(id).Text(session_id))
                          .status());
      return Changed(connection, map, id);
    });
  }

  absl::StatusOr<MapRecord> DeleteMap(const std::string& name) override {
    RETURN_IF_ERROR(CheckMapName(name));
    return pool_->Transaction<MapRecord>([&](Connection& connection) -> absl::StatusOr<MapRecord> {
      int64_t id = 0;
      ASSIGN_OR_RETURN(MapRecord record, ReadMap(connection, name, /*lock=*/true, &id));
      // ON DELETE CASCADE removes the trajectory rows; the sessions stay.
      RETURN_IF_ERROR(
          connection.Execute("DELETE FROM slam_map WHERE id = $1", Params().Int64(id)).status());
      return record;
    });
  }

  absl::StatusOr<SlamLease> AcquireMapLease(const std::string& map, const std::string& owner,
                                            const std::string& address,
                                            double ttl_seconds) override {
    RETURN_IF_ERROR(CheckMapName(map));
    RETURN_IF_ERROR(CheckLeaseRequest(owner, ttl_seconds));
    return pool_->Transaction<SlamLease>([&](Connection& connection) -> absl::StatusOr<SlamLease> {
      // The map's row locked: two servers asking at once queue, the second sees the first's lease.
      int64_t id = 0;
      ASSIGN_OR_RETURN(MapRecord record, ReadMap(connection, map, /*lock=*/true, &id));
      // The database's clock, read after the lock was granted (as a session's lease).
      ASSIGN_OR_RETURN(Result clock,
                       connection.Execute("SELECT extract(epoch FROM clock_timestamp())::float8"));
      const SlamLease lease =
          LeaseAfter(record.lease, owner, address, ttl_seconds, clock.Double(0, 0));
      if (lease.owner != owner) return lease;  // held by another: nothing to write
      RETURN_IF_ERROR(connection
                          .Execute("UPDATE slam_map SET lease_owner = $1, lease_address = $2, "
                                   "lease_expires_at = $3 WHERE id = $4",
                                   Params()
                                       .Text(lease.owner)
                                       .Text(lease.address)
                                       .Double(lease.expires_at)
                                       .Int64(id))
                          .status());
      return lease;
    });
  }

  absl::Status ReleaseMapLease(const std::string& map, const std::string& owner) override {
    RETURN_IF_ERROR(CheckMapName(map));
    return pool_->Transaction([&](Connection& connection) {
      return connection
          .Execute(absl::StrCat("UPDATE slam_map SET ", kClearSlamLease,
                                " WHERE name = $1 AND lease_owner = $2"),
                   Params().Text(map).Text(owner))
          .status();
    });
  }

  absl::StatusOr<int64_t> PublishTrajectoryFeed(const std::string& session_id,
                                                const TrajectoryFeedUpdate& update) override {
    return pool_->Transaction<int64_t>([&](Connection& connection) -> absl::StatusOr<int64_t> {
      ASSIGN_OR_RETURN(Result session,
                       connection.Execute("SELECT 1 FROM slam_session WHERE id = $1",
                                          Params().Text(session_id)));
      if (session.rows() == 0) return MapSessionNotFound(session_id);
      if (update.replace) {
        RETURN_IF_ERROR(connection
                            .Execute("DELETE FROM slam_map_feed_node WHERE session_id = $1",
                                     Params().Text(session_id))
                            .status());
      } else if (!update.dropped.empty()) {
        RETURN_IF_ERROR(connection
                            .Execute("DELETE FROM slam_map_feed_node WHERE session_id = $1 AND "
                                     "scan = ANY($2)",
                                     Params().Text(session_id).Int64Array(update.dropped))
                            .status());
      }
      if (!update.added.empty()) {
        // One statement for the new nodes: arrays of scans and of points, unnested.
        std::vector<int64_t> scans;
        std::vector<absl::string_view> points;
        for (const FeedNodePoints& node : update.added) {
          scans.push_back(node.scan);
          points.push_back(node.points);
        }
        RETURN_IF_ERROR(
            connection
                .Execute("INSERT INTO slam_map_feed_node (session_id, scan, points) SELECT $1, "
                         "s, p FROM unnest($2::BIGINT[], $3::BYTEA[]) AS n(s, p) ON CONFLICT "
                         "(session_id, scan) DO UPDATE SET points = excluded.points",
                         Params().Text(session_id).Int64Array(scans).BytesArray(points))
                .status());
      }
      ASSIGN_OR_RETURN(
          Result version,
          connection.Execute(
              "INSERT INTO slam_map_feed (session_id, version, scans_processed, updated_at, "
              "poses) VALUES ($1, 1, $2, $3, $4) ON CONFLICT (session_id) DO UPDATE SET version "
              "= slam_map_feed.version + 1, scans_processed = excluded.scans_processed, "
              "updated_at = excluded.updated_at, poses = excluded.poses RETURNING version",
              Params()
                  .Text(session_id)
                  .Int64(update.scans_processed)
                  .Double(NowSeconds())
                  .Bytes(update.poses)));
      if (version.rows() != 1) return absl::InternalError("publishing a feed gave no version");
      return version.Int64(0, 0);
    });
  }

  absl::StatusOr<std::optional<TrajectoryFeed>> ReadTrajectoryFeed(const std::string& session_id,
                                                                   int64_t after_version,
                                                                   int64_t after_scan) override {
    // Both reads in one transaction: the points are those of the poses read.
    return pool_->Transaction<std::optional<TrajectoryFeed>>(
        [&](Connection& connection) -> absl::StatusOr<std::optional<TrajectoryFeed>> {
          ASSIGN_OR_RETURN(Result row,
                           connection.Execute("SELECT version, scans_processed, poses "
                                              "FROM slam_map_feed WHERE session_id = $1 AND "
                                              "version > $2",
                                              Params().Text(session_id).Int64(after_version)));
          if (row.rows() == 0) return std::optional<TrajectoryFeed>();
          TrajectoryFeed feed;
          feed.version = row.Int64(0, 0);
          feed.scans_processed = row.Int64(0, 1);
          feed.poses = std::string(row.Bytes(0, 2));
          ASSIGN_OR_RETURN(Result points,
                           connection.Execute("SELECT scan, points FROM slam_map_feed_node WHERE "
                                              "session_id = $1 AND scan > $2 ORDER BY scan",
                                              Params().Text(session_id).Int64(after_scan)));
          for (int i = 0; i < points.rows(); ++i) {
            feed.points.push_back(
                FeedNodePoints{points.Int64(i, 0), std::string(points.Bytes(i, 1))});
          }
          return std::optional<TrajectoryFeed>(std::move(feed));
        });
  }

 private:
  // The map with its trajectories; `lock` locks its row for the rest of the transaction.
  static absl::StatusOr<MapRecord> ReadMap(Connection& connection, const std::string& name,
                                           bool lock, int64_t* id) {
    ASSIGN_OR_RETURN(Result rows, connection.Execute(absl::StrCat("SELECT ", kMapColumns,
                                                                  " FROM slam_map m WHERE "
                                                                  "m.name = $1",
                                                                  lock ? " FOR UPDATE" : ""),
                                                     Params().Text(name)));
    if (rows.rows() == 0) return MapNotFound(name);
    MapRecord map = ReadMapRow(PgRow(rows, 0), id);
    ASSIGN_OR_RETURN(Result trajectories,
                     connection.Execute(SelectMapTrajectories("WHERE t.map_id = $1"),
                                        Params().Int64(*id)));
    for (int row = 0; row < trajectories.rows(); ++row) {
      int64_t map_id = 0;
      ASSIGN_OR_RETURN(MapTrajectoryRecord trajectory,
                       ReadMapTrajectoryRow(PgRow(trajectories, row), &map_id));
      map.trajectories.push_back(std::move(trajectory));
    }
    return map;
  }

  // Rows changed: 0 when the session has no trajectory in the map.
  static absl::StatusOr<int64_t> SetTie(Connection& connection, int64_t id,
                                        const std::string& session_id, const MapTie& tie,
                                        const std::string& follow) {
    ASSIGN_OR_RETURN(Result result,
                     connection.Execute("UPDATE slam_map_trajectory SET tie_x = $1, tie_y = $2, "
                                        "tie_theta = $3, follow = $4 "
                                        "WHERE map_id = $5 AND session_id = $6",
                                        Params()
                                            .Double(tie.x)
                                            .Double(tie.y)
                                            .Double(tie.theta)
                                            .OptionalBytes(follow)
                                            .Int64(id)
                                            .Text(session_id)));
    return result.affected();
  }

  // As sqlite_map_store.cc's ChangedLocked: anchor the frame if needed, count the revision.
  static absl::StatusOr<MapRecord> Changed(Connection& connection, const std::string& name,
                                           int64_t id) {
    ASSIGN_OR_RETURN(MapRecord map, ReadMap(connection, name, /*lock=*/false, &id));
    if (std::optional<std::string> anchor = TrajectoryToAnchor(map); anchor.has_value()) {
      RETURN_IF_ERROR(SetTie(connection, id, *anchor, MapTie{}, "").status());
    }
    RETURN_IF_ERROR(connection
                        .Execute("UPDATE slam_map SET revision = revision + 1, updated_at = $1 "
                                 "WHERE id = $2",
                                 Params().Double(NowSeconds()).Int64(id))
                        .status());
    return ReadMap(connection, name, /*lock=*/false, &id);
  }

  std::shared_ptr<pg::Pool> pool_;
};

}  // namespace

std::unique_ptr<MapStore> NewPostgresMapStore(std::shared_ptr<pg::Pool> pool) {
  return std::make_unique<PostgresMapStore>(std::move(pool));
}

}  // namespace waymark::storage
