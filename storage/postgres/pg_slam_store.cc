// SlamStore on PostgreSQL (issue 19), the port of sqlite_slam_store.cc: this file holds the SQL and
// the transactions; the checks, the reading of rows and the messages are shared with the SQLite
// store (slam_records.h), so both backends accept, refuse and report the same things.
//
// Where SQLite's one connection serialises everything, here several servers may write at once.
// A checkpoint, a delete and a lease change therefore lock their session's row before reading it:
// two writers of one session queue (the second then sees the first one's trajectory, or lease)
// instead of both appending at the same seq (or both taking the session).

#include <array>
#include <cstdint>
#include <limits>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"
#include "storage/postgres/pg.h"
#include "storage/postgres/pg_stores.h"
#include "storage/slam_records.h"
#include "storage/slam_store.h"
#include "storage/status_macros.h"
#include "storage/store_util.h"
#include "storage/stored_row.h"

namespace waymark::storage {
namespace {

using pg::Connection;
using pg::Params;
using pg::Result;
using pg::UniqueViolation;

// z, qx, qy, qz, qw of a 3-D pose; all NULL for a laser pose.
std::array<std::optional<double>, 5> Pose3Columns(const TrajectoryPoseRecord& pose) {
  if (!pose.pose3.has_value()) return {};
  const Pose3Extra& extra = *pose.pose3;
  return {extra.z, extra.qx, extra.qy, extra.qz, extra.qw};
}

// The new poses as one array per column, for InsertPoses' single INSERT: $1 is the session id,
// $2.. the arrays in the INSERT's column order.
Params PoseArrays(const std::string& id, const std::vector<TrajectoryPoseRecord>& poses) {
  std::vector<int64_t> seq;
  std::vector<double> stamp, x, y, theta;
  std::vector<absl::string_view> covariance;
  std::array<std::vector<std::optional<double>>, 5> pose3;  // Pose3Columns' columns
  for (const TrajectoryPoseRecord& pose : poses) {
    seq.push_back(pose.seq);
    stamp.push_back(pose.stamp);
    x.push_back(pose.x);
    y.push_back(pose.y);
    theta.push_back(pose.theta);
    covariance.push_back(CovarianceBytes(pose));
    const std::array<std::optional<double>, 5> extra = Pose3Columns(pose);
    for (size_t column = 0; column < extra.size(); ++column) pose3[column].push_back(extra[column]);
  }
  Params params;
  params.Text(id).Int64Array(seq).DoubleArray(stamp).DoubleArray(x).DoubleArray(y);
  params.DoubleArray(theta).BytesArray(covariance);
  for (const auto& column : pose3) params.DoubleArray(column);
  return params;
}

class PostgresSlamStore final : public SlamStore {
 public:
  explicit PostgresSlamStore(std::shared_ptr<pg::Pool> pool) : pool_(std::move(pool)) {}

  absl::StatusOr<SlamSessionRecord> CreateSession(const SlamSessionRecord& session) override {
    ASSIGN_OR_RETURN(SlamSessionRecord created, NewSlamSession(session));
    absl::Status insert = pool_->Transaction([&](Connection& connection) {
      return connection
          .Execute(
              "INSERT INTO slam_session (id, robot_id, name, kind, config, state, "
              "created_at, updated_at, scans_processed, map_revision, segments, "
              "last_scan_stamp, last_odometry_stamp) "
              "VALUES ($1, $2, $3, $4, $5, $6, $7, $8, $9, $10, $11, $12, $13)",
              Params()
                  .Text(created.id)
                  .Text(created.robot_id)
                  .Text(created.name)
                  .Text(created.kind)
                  .Bytes(created.config)
                  .Text(SlamSessionStateName(created.state))
                  .Double(created.created_at)
                  .Double(created.updated_at)
                  .Int64(created.scans_processed)
                  .Int64(created.map_revision)
                  .Int32(created.segments)
                  .OptionalDouble(created.last_scan_stamp)
                  .OptionalDouble(created.last_odometry_stamp),
              UniqueViolation::kAlreadyExists)
          .status();
    });
    if (absl::IsAlreadyExists(insert)) return SlamSessionAlreadyExists(created.id);
    RETURN_IF_ERROR(insert);
    return created;
  }

  absl::StatusOr<SlamSessionRecord> GetSession(const std::string& id) override {
    return pool_->Run<SlamSessionRecord>(
        [&](Connection& connection) { return ReadSession(connection, id, true); });
  }

  absl::StatusOr<std::vector<SlamSessionRecord>> ListSessions(
      const std::string& robot_id) override {
    using Sessions = std::vector<SlamSessionRecord>;
    return pool_->Run<Sessions>([&](Connection& connection) -> absl::StatusOr<Sessions> {
      // Ids in byte order, as SQLite compares them, whatever the database's collation.
      ASSIGN_OR_RETURN(
          Result rows,
          connection.Execute(SelectSlamSessions(false,
                                                "WHERE ($1 = '' OR s.robot_id = $1) "
                                                "ORDER BY s.created_at, s.id COLLATE \"C\""),
                             Params().Text(robot_id)));
      Sessions sessions;
      sessions.reserve(static_cast<size_t>(rows.rows()));
      for (int row = 0; row < rows.rows(); ++row) {
        ASSIGN_OR_RETURN(SlamSessionRecord session, ReadSlamSessionRow(PgRow(rows, row)));
        sessions.push_back(std::move(session));
      }
      return sessions;
    });
  }

  absl::StatusOr<int64_t> CountSessions(SlamSessionState state) override {
    return pool_->Run<int64_t>([&](Connection& connection) -> absl::StatusOr<int64_t> {
      ASSIGN_OR_RETURN(Result count,
                       connection.Execute("SELECT COUNT(*) FROM slam_session WHERE state = $1",
                                          Params().Text(SlamSessionStateName(state))));
      return count.Int64(0, 0);
    });
  }

  absl::Status AppendJournal(const std::vector<SlamJournalEntry>& entries,
                             const std::string& lease_owner) override {
    RETURN_IF_ERROR(CheckJournalEntries(entries));
    if (entries.empty()) return absl::OkStatus();
    // One statement per session of the batch (arrays of its seqs and messages).
    std::map<std::string, std::pair<std::vector<int64_t>, std::vector<absl::string_view>>> by_session;
    for (const SlamJournalEntry& entry : entries) {
      auto& [seqs, messages] = by_session[entry.session_id];
      seqs.push_back(entry.seq);
      messages.push_back(entry.message);
    }
    return pool_->Transaction([&](Connection& connection) -> absl::Status {
      for (const auto& [id, columns] : by_session) {
        // Skips a closed, deleted or (when fenced) leased-away session, as SQLite does.
        RETURN_IF_ERROR(connection
                            .Execute("INSERT INTO slam_journal (session_id, seq, message) "
                                     "SELECT $1, e.seq, e.message "
                                     "FROM unnest($2::bigint[], $3::bytea[]) AS e(seq, message) "
                                     "WHERE EXISTS (SELECT 1 FROM slam_session WHERE id = $1 "
                                     "AND state = 'open' AND ($4 = '' OR lease_owner = $4))",
                                     Params()
                                         .Text(id)
                                         .Int64Array(columns.first)
                                         .BytesArray(columns.second)
                                         .Text(lease_owner),
                                     UniqueViolation::kAlreadyExists)
                            .status());
      }
      return absl::OkStatus();
    });
  }

  absl::StatusOr<std::vector<SlamJournalEntry>> LoadJournal(const std::string& id) override {
    using Entries = std::vector<SlamJournalEntry>;
    return pool_->Run<Entries>([&](Connection& connection) -> absl::StatusOr<Entries> {
      ASSIGN_OR_RETURN(SlamSessionRecord session, ReadSession(connection, id, false));
      ASSIGN_OR_RETURN(Result rows,
                       connection.Execute("SELECT seq, message FROM slam_journal "
                                          "WHERE session_id = $1 AND seq > $2 ORDER BY seq",
                                          Params().Text(id).Int64(session.journal_through)));
      Entries entries;
      entries.reserve(static_cast<size_t>(rows.rows()));
      for (int row = 0; row < rows.rows(); ++row) {
        PgRow stored(rows, row);
        entries.push_back(SlamJournalEntry{id, stored.Int64(0), std::string(stored.Bytes(1))});
      }
      return entries;
    });
  }

  absl::Status WriteCheckpoint(const std::string& id, const SlamCheckpoint& checkpoint) override {
    return Checkpoint(id, checkpoint, /*close=*/false);
  }

  absl::Status CloseSession(const std::string& id, const SlamCheckpoint& checkpoint) override {
    return Checkpoint(id, checkpoint, /*close=*/true);
  }

  absl::StatusOr<std::vector<TrajectoryPoseRecord>> LoadTrajectory(const std::string& id) override {
    using Poses = std::vector<TrajectoryPoseRecord>;
    return pool_->Run<Poses>([&](Connection& connection) -> absl::StatusOr<Poses> {
      RETURN_IF_ERROR(ReadSession(connection, id, false).status());  // NOT_FOUND
      ASSIGN_OR_RETURN(Result rows, connection.Execute(absl::StrCat("SELECT ", kTrajectoryColumns,
                                                                    " FROM slam_trajectory "
                                                                    "WHERE session_id = $1 "
                                                                    "ORDER BY seq"),
                                                       Params().Text(id)));
      Poses poses;
      poses.reserve(static_cast<size_t>(rows.rows()));
      for (int row = 0; row < rows.rows(); ++row) {
        ASSIGN_OR_RETURN(TrajectoryPoseRecord pose,
                         ReadTrajectoryPoseRow(id, row, PgRow(rows, row)));
        poses.push_back(pose);
      }
      return poses;
    });
  }

  absl::StatusOr<SlamLease> AcquireLease(const std::string& id, const std::string& owner,
                                         const std::string& address,
                                         double ttl_seconds) override {
    RETURN_IF_ERROR(CheckLeaseRequest(owner, ttl_seconds));
    return pool_->Transaction<SlamLease>([&](Connection& connection) -> absl::StatusOr<SlamLease> {
      // The row lock makes the read, the decision and the write one step against every other
      // server: two servers asking at once queue, and the second sees the first one's lease.
      RETURN_IF_ERROR(LockSession(connection, id));
      ASSIGN_OR_RETURN(SlamSessionRecord session, ReadSession(connection, id, false));
      // The database's clock, read after the lock was granted (clock_timestamp(), not the
      // transaction's start, which may be long before): one clock for every server, so theirs
      // need not agree.
      ASSIGN_OR_RETURN(Result clock,
                       connection.Execute("SELECT extract(epoch FROM clock_timestamp())::float8"));
      ASSIGN_OR_RETURN(SlamLease lease, LeaseAfterAcquire(session, owner, address, ttl_seconds,
                                                          clock.Double(0, 0)));
      if (lease.owner != owner) return lease;  // held by another: nothing to write
      RETURN_IF_ERROR(connection
                          .Execute("UPDATE slam_session SET lease_owner = $1, lease_address = $2, "
                                   "lease_expires_at = $3 WHERE id = $4",
                                   Params()
                                       .Text(lease.owner)
                                       .Text(lease.address)
                                       .Double(lease.expires_at)
                                       .Text(id))
                          .status());
      return lease;
    });
  }

  absl::Status ReleaseLease(const std::string& id, const std::string& owner) override {
    return pool_->Transaction([&](Connection& connection) -> absl::Status {
      RETURN_IF_ERROR(LockSession(connection, id));
      ASSIGN_OR_RETURN(SlamSessionRecord session, ReadSession(connection, id, false));
      if (session.lease.owner != owner) return absl::OkStatus();  // not ours to give up
      return connection
          .Execute(absl::StrCat("UPDATE slam_session SET ", kClearSlamLease, " WHERE id = $1"),
                   Params().Text(id))
          .status();
    });
  }

  absl::StatusOr<SlamSessionRecord> DeleteSession(const std::string& id) override {
    // The read and the delete in one transaction, so the record returned is exactly what went.
    using Deleted = absl::StatusOr<SlamSessionRecord>;
    return pool_->Transaction<SlamSessionRecord>([&](Connection& connection) -> Deleted {
      RETURN_IF_ERROR(LockSession(connection, id));
      ASSIGN_OR_RETURN(SlamSessionRecord session, ReadSession(connection, id, false));
      // ON DELETE CASCADE removes the trajectory rows within this statement.
      RETURN_IF_ERROR(
          connection.Execute("DELETE FROM slam_session WHERE id = $1", Params().Text(id)).status());
      return session;
    });
  }

 private:
  // Locks the session's row until the transaction ends; NOT_FOUND when there is none. The reads
  // that follow are separate statements, so (READ COMMITTED) they see what a writer that held the
  // lock before committed.
  static absl::Status LockSession(Connection& connection, const std::string& id) {
    ASSIGN_OR_RETURN(Result locked,
                     connection.Execute("SELECT 1 FROM slam_session WHERE id = $1 FOR UPDATE",
                                        Params().Text(id)));
    if (locked.rows() == 0) return SlamSessionNotFound(id);
    return absl::OkStatus();
  }

  static absl::StatusOr<SlamSessionRecord> ReadSession(Connection& connection,
                                                       const std::string& id,
                                                       bool with_checkpoint) {
    ASSIGN_OR_RETURN(Result rows,
                     connection.Execute(SelectSlamSessions(with_checkpoint, "WHERE s.id = $1"),
                                        Params().Text(id)));
    if (rows.rows() == 0) return SlamSessionNotFound(id);
    return ReadSlamSessionRow(PgRow(rows, 0));
  }

  absl::Status Checkpoint(const std::string& id, const SlamCheckpoint& checkpoint, bool close) {
    RETURN_IF_ERROR(CheckSlamCheckpoint(checkpoint));
    return pool_->Transaction([&](Connection& connection) -> absl::Status {
      RETURN_IF_ERROR(LockSession(connection, id));
      ASSIGN_OR_RETURN(SlamSessionRecord session, ReadSession(connection, id, false));
      RETURN_IF_ERROR(CheckCheckpointApplies(session, checkpoint));
      RETURN_IF_ERROR(InsertPoses(connection, id, checkpoint.new_poses));
      const double now = NowSeconds();
      const SlamSessionState state = close ? SlamSessionState::kClosed : SlamSessionState::kOpen;
      // The journal the checkpoint includes goes with it; a closed session keeps none.
      RETURN_IF_ERROR(connection
                          .Execute("DELETE FROM slam_journal WHERE session_id = $1 AND seq <= $2",
                                   Params().Text(id).Int64(
                                       close ? std::numeric_limits<int64_t>::max()
                                             : checkpoint.journal_through))
                          .status());
      // Closing also gives the lease up: a closed session has no holder.
      return connection
          .Execute(
              absl::StrCat(
                  "UPDATE slam_session SET checkpoint = $1, checkpoint_at = $2, "
                  "updated_at = $2, scans_processed = $3, map_revision = $4, segments = $5, "
                  "last_scan_stamp = $6, last_odometry_stamp = $7, state = $8, "
                  "journal_through = $10, map_check = $11",
                  close ? absl::StrCat(", ", kClearSlamLease) : "", " WHERE id = $9"),
              Params()
                  .Bytes(checkpoint.state)
                  .Double(now)
                  .Int64(checkpoint.scans_processed)
                  .Int64(checkpoint.map_revision)
                  .Int32(checkpoint.segments)
                  .OptionalDouble(checkpoint.last_scan_stamp)
                  .OptionalDouble(checkpoint.last_odometry_stamp)
                  .Text(SlamSessionStateName(state))
                  .Text(id)
                  .Int64(checkpoint.journal_through)
                  .OptionalBytes(checkpoint.map_check))
          .status();
    });
  }

  // All of a checkpoint's poses in one statement (one round trip however many there are), inside
  // the checkpoint's transaction; their seq are already checked.
  static absl::Status InsertPoses(Connection& connection, const std::string& id,
                                  const std::vector<TrajectoryPoseRecord>& poses) {
    if (poses.empty()) return absl::OkStatus();
    return connection
        .Execute(
            "INSERT INTO slam_trajectory "
            "(session_id, seq, stamp, x, y, theta, covariance, z, qx, qy, qz, qw) "
            "SELECT $1, p.* FROM unnest($2::bigint[], $3::float8[], $4::float8[], "
            "$5::float8[], $6::float8[], $7::bytea[], $8::float8[], $9::float8[], "
            "$10::float8[], $11::float8[], $12::float8[]) AS p",
            PoseArrays(id, poses))
        .status();
  }

  std::shared_ptr<pg::Pool> pool_;
};

}  // namespace

std::unique_ptr<SlamStore> NewPostgresSlamStore(std::shared_ptr<pg::Pool> pool) {
  return std::make_unique<PostgresSlamStore>(std::move(pool));
}

}  // namespace waymark::storage
