// SlamStore on SQLite: one connection behind a mutex, one transaction per mutating call. What is
// not SQL (checks, row reading, messages) is shared with the PostgreSQL store (slam_records.h).

#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "storage/migrations.h"
#include "storage/slam_records.h"
#include "storage/slam_store.h"
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

class SqliteSlamStore final : public SlamStore {
 public:
  explicit SqliteSlamStore(Connection connection) : connection_(std::move(connection)) {}

  absl::StatusOr<SlamSessionRecord> CreateSession(const SlamSessionRecord& session) override {
    ASSIGN_OR_RETURN(SlamSessionRecord created, NewSlamSession(session));
    std::lock_guard<std::mutex> lock(mutex_);
    ASSIGN_OR_RETURN(Statement stmt,
                     connection_.Prepare(
                         "INSERT INTO slam_session (id, robot_id, name, kind, config, state, "
                         "created_at, updated_at, scans_processed, map_revision, segments, "
                         "last_scan_stamp, last_odometry_stamp) "
                         "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)"));
    RETURN_IF_ERROR(stmt.BindText(1, created.id));
    RETURN_IF_ERROR(stmt.BindText(2, created.robot_id));
    RETURN_IF_ERROR(stmt.BindText(3, created.name));
    RETURN_IF_ERROR(stmt.BindText(4, created.kind));
    RETURN_IF_ERROR(stmt.BindBlob(5, created.config.data(), created.config.size()));
    RETURN_IF_ERROR(stmt.BindText(6, SlamSessionStateName(created.state)));
    RETURN_IF_ERROR(stmt.BindDouble(7, created.created_at));
    RETURN_IF_ERROR(stmt.BindDouble(8, created.updated_at));
    RETURN_IF_ERROR(stmt.BindInt64(9, created.scans_processed));
    RETURN_IF_ERROR(stmt.BindInt64(10, created.map_revision));
    RETURN_IF_ERROR(stmt.BindInt64(11, created.segments));
    RETURN_IF_ERROR(stmt.BindOptionalDouble(12, created.last_scan_stamp));
    RETURN_IF_ERROR(stmt.BindOptionalDouble(13, created.last_odometry_stamp));
    absl::Status run = stmt.Run(UniqueViolation::kAlreadyExists);
    if (absl::IsAlreadyExists(run)) return SlamSessionAlreadyExists(created.id);
    RETURN_IF_ERROR(run);
    return created;
  }

  absl::StatusOr<SlamSessionRecord> GetSession(const std::string& id) override {
    std::lock_guard<std::mutex> lock(mutex_);
    return GetSessionLocked(id, /*with_checkpoint=*/true);
  }

  absl::StatusOr<std::vector<SlamSessionRecord>> ListSessions(const std::string& robot_id) override {
    std::lock_guard<std::mutex> lock(mutex_);
    ASSIGN_OR_RETURN(Statement stmt,
                     connection_.Prepare(SelectSlamSessions(
                         false, "WHERE (?1 = '' OR s.robot_id = ?1) ORDER BY s.created_at, s.id")));
    RETURN_IF_ERROR(stmt.BindText(1, robot_id));
    std::vector<SlamSessionRecord> sessions;
    while (true) {
      ASSIGN_OR_RETURN(StepResult step, stmt.Step());
      if (step == StepResult::kDone) break;
      ASSIGN_OR_RETURN(SlamSessionRecord session, ReadSlamSessionRow(SqliteRow(stmt)));
      sessions.push_back(std::move(session));
    }
    return sessions;
  }

  absl::StatusOr<int64_t> CountSessions(SlamSessionState state) override {
    std::lock_guard<std::mutex> lock(mutex_);
    ASSIGN_OR_RETURN(Statement stmt,
                     connection_.Prepare("SELECT COUNT(*) FROM slam_session WHERE state = ?"));
    RETURN_IF_ERROR(stmt.BindText(1, SlamSessionStateName(state)));
    ASSIGN_OR_RETURN(StepResult step, stmt.Step());
    if (step != StepResult::kRow) return absl::InternalError("COUNT returned no row");
    return stmt.ColumnInt64(0);
  }

  absl::Status WriteCheckpoint(const std::string& id, const SlamCheckpoint& checkpoint) override {
    std::lock_guard<std::mutex> lock(mutex_);
    return CheckpointLocked(id, checkpoint, /*close=*/false);
  }

  absl::Status CloseSession(const std::string& id, const SlamCheckpoint& checkpoint) override {
    std::lock_guard<std::mutex> lock(mutex_);
    return CheckpointLocked(id, checkpoint, /*close=*/true);
  }

  absl::Status AppendJournal(const std::vector<SlamJournalEntry>& entries,
                             const std::string& lease_owner) override {
    RETURN_IF_ERROR(CheckJournalEntries(entries));
    if (entries.empty()) return absl::OkStatus();
    std::lock_guard<std::mutex> lock(mutex_);
    ASSIGN_OR_RETURN(Transaction txn, Transaction::Begin(connection_));
    // Skips a closed, deleted or (when fenced) leased-away session instead of failing the batch,
    // which holds other sessions' messages too.
    ASSIGN_OR_RETURN(Statement insert,
                     connection_.Prepare(
                         "INSERT INTO slam_journal (session_id, seq, message) "
                         "SELECT ?1, ?2, ?3 WHERE EXISTS (SELECT 1 FROM slam_session "
                         "WHERE id = ?1 AND state = 'open' AND (?4 = '' OR lease_owner = ?4))"));
    for (const SlamJournalEntry& entry : entries) {
      insert.Reset();
      RETURN_IF_ERROR(insert.BindText(1, entry.session_id));
      RETURN_IF_ERROR(insert.BindInt64(2, entry.seq));
      RETURN_IF_ERROR(insert.BindBlob(3, entry.message.data(), entry.message.size()));
      RETURN_IF_ERROR(insert.BindText(4, lease_owner));
      RETURN_IF_ERROR(insert.Run(UniqueViolation::kAlreadyExists));
    }
    return txn.Commit();
  }

  absl::StatusOr<std::vector<SlamJournalEntry>> LoadJournal(const std::string& id) override {
    std::lock_guard<std::mutex> lock(mutex_);
    ASSIGN_OR_RETURN(SlamSessionRecord session, GetSessionLocked(id, false));
    ASSIGN_OR_RETURN(Statement stmt,
                     connection_.Prepare("SELECT seq, message FROM slam_journal "
                                         "WHERE session_id = ? AND seq > ? ORDER BY seq"));
    RETURN_IF_ERROR(stmt.BindText(1, id));
    RETURN_IF_ERROR(stmt.BindInt64(2, session.journal_through));
    std::vector<SlamJournalEntry> entries;
    while (true) {
      ASSIGN_OR_RETURN(StepResult step, stmt.Step());
      if (step == StepResult::kDone) break;
      SqliteRow row(stmt);
      entries.push_back(SlamJournalEntry{id, row.Int64(0), std::string(row.Bytes(1))});
    }
    return entries;
  }

  absl::StatusOr<std::vector<TrajectoryPoseRecord>> LoadTrajectory(const std::string& id) override {
    std::lock_guard<std::mutex> lock(mutex_);
    ASSIGN_OR_RETURN(SlamSessionRecord session, GetSessionLocked(id, false));
    ASSIGN_OR_RETURN(Statement stmt,
                     connection_.Prepare(absl::StrCat("SELECT ", kTrajectoryColumns,
                                                      " FROM slam_trajectory "
                                                      "WHERE session_id = ? ORDER BY seq")));
    RETURN_IF_ERROR(stmt.BindText(1, id));
    std::vector<TrajectoryPoseRecord> poses;
    poses.reserve(static_cast<size_t>(session.trajectory_length));
    while (true) {
      ASSIGN_OR_RETURN(StepResult step, stmt.Step());
      if (step == StepResult::kDone) break;
      ASSIGN_OR_RETURN(TrajectoryPoseRecord pose,
                       ReadTrajectoryPoseRow(id, static_cast<int64_t>(poses.size()),
                                             SqliteRow(stmt)));
      poses.push_back(pose);
    }
    return poses;
  }

  // "Now" is this process's clock: a SQLite file is served by one server (database_lock.h), so
  // there is no other clock to disagree with.
  absl::StatusOr<SlamLease> AcquireLease(const std::string& id, const std::string& owner,
                                         const std::string& address,
                                         double ttl_seconds) override {
    RETURN_IF_ERROR(CheckLeaseRequest(owner, ttl_seconds));
    std::lock_guard<std::mutex> lock(mutex_);
    // The write transaction holds the file's write lock from the read to the commit, so another
    // connection cannot take the lease in between.
    ASSIGN_OR_RETURN(Transaction txn, Transaction::Begin(connection_));
    ASSIGN_OR_RETURN(SlamSessionRecord session, GetSessionLocked(id, /*with_checkpoint=*/false));
    ASSIGN_OR_RETURN(SlamLease lease,
                     LeaseAfterAcquire(session, owner, address, ttl_seconds, NowSeconds()));
    if (lease.owner != owner) return lease;  // held by another: nothing to write
    ASSIGN_OR_RETURN(Statement update,
                     connection_.Prepare("UPDATE slam_session SET lease_owner = ?, "
                                         "lease_address = ?, lease_expires_at = ? WHERE id = ?"));
    RETURN_IF_ERROR(update.BindText(1, lease.owner));
    RETURN_IF_ERROR(update.BindText(2, lease.address));
    RETURN_IF_ERROR(update.BindDouble(3, lease.expires_at));
    RETURN_IF_ERROR(update.BindText(4, id));
    RETURN_IF_ERROR(update.Run());
    RETURN_IF_ERROR(txn.Commit());
    return lease;
  }

  absl::Status ReleaseLease(const std::string& id, const std::string& owner) override {
    std::lock_guard<std::mutex> lock(mutex_);
    ASSIGN_OR_RETURN(Transaction txn, Transaction::Begin(connection_));
    ASSIGN_OR_RETURN(SlamSessionRecord session, GetSessionLocked(id, /*with_checkpoint=*/false));
    if (session.lease.owner != owner) return absl::OkStatus();  // not ours to give up
    ASSIGN_OR_RETURN(Statement update,
                     connection_.Prepare(absl::StrCat("UPDATE slam_session SET ", kClearSlamLease,
                                                      " WHERE id = ?")));
    RETURN_IF_ERROR(update.BindText(1, id));
    RETURN_IF_ERROR(update.Run());
    return txn.Commit();
  }

  absl::StatusOr<SlamSessionRecord> DeleteSession(const std::string& id) override {
    std::lock_guard<std::mutex> lock(mutex_);
    // The read and the delete in one transaction, so the record returned is exactly what went.
    ASSIGN_OR_RETURN(Transaction txn, Transaction::Begin(connection_));
    ASSIGN_OR_RETURN(SlamSessionRecord session, GetSessionLocked(id, /*with_checkpoint=*/false));
    // ON DELETE CASCADE removes the trajectory rows within this statement.
    ASSIGN_OR_RETURN(Statement stmt, connection_.Prepare("DELETE FROM slam_session WHERE id = ?"));
    RETURN_IF_ERROR(stmt.BindText(1, id));
    RETURN_IF_ERROR(stmt.Run());
    RETURN_IF_ERROR(txn.Commit());
    return session;
  }

 private:
  absl::StatusOr<SlamSessionRecord> GetSessionLocked(const std::string& id, bool with_checkpoint) {
    ASSIGN_OR_RETURN(Statement stmt,
                     connection_.Prepare(SelectSlamSessions(with_checkpoint, "WHERE s.id = ?")));
    RETURN_IF_ERROR(stmt.BindText(1, id));
    ASSIGN_OR_RETURN(StepResult step, stmt.Step());
    if (step == StepResult::kDone) return SlamSessionNotFound(id);
    return ReadSlamSessionRow(SqliteRow(stmt));
  }

  absl::Status CheckpointLocked(const std::string& id, const SlamCheckpoint& checkpoint,
                                bool close) {
    RETURN_IF_ERROR(CheckSlamCheckpoint(checkpoint));
    ASSIGN_OR_RETURN(Transaction txn, Transaction::Begin(connection_));
    ASSIGN_OR_RETURN(SlamSessionRecord session, GetSessionLocked(id, false));
    RETURN_IF_ERROR(CheckCheckpointApplies(session, checkpoint));
    RETURN_IF_ERROR(InsertPosesLocked(id, checkpoint.new_poses));
    // Closing also gives the lease up: a closed session has no holder.
    ASSIGN_OR_RETURN(Statement update,
                     connection_.Prepare(absl::StrCat(
                         "UPDATE slam_session SET checkpoint = ?, checkpoint_at = ?, "
                         "updated_at = ?, scans_processed = ?, map_revision = ?, segments = ?, "
                         "last_scan_stamp = ?, last_odometry_stamp = ?, state = ?, "
                         "journal_through = ?, map_check = ?",
                         close ? absl::StrCat(", ", kClearSlamLease) : "", " WHERE id = ?")));
    const double now = NowSeconds();
    RETURN_IF_ERROR(update.BindBlob(1, checkpoint.state.data(), checkpoint.state.size()));
    RETURN_IF_ERROR(update.BindDouble(2, now));
    RETURN_IF_ERROR(update.BindDouble(3, now));
    RETURN_IF_ERROR(update.BindInt64(4, checkpoint.scans_processed));
    RETURN_IF_ERROR(update.BindInt64(5, checkpoint.map_revision));
    RETURN_IF_ERROR(update.BindInt64(6, checkpoint.segments));
    RETURN_IF_ERROR(update.BindOptionalDouble(7, checkpoint.last_scan_stamp));
    RETURN_IF_ERROR(update.BindOptionalDouble(8, checkpoint.last_odometry_stamp));
    RETURN_IF_ERROR(update.BindText(
        9, SlamSessionStateName(close ? SlamSessionState::kClosed : SlamSessionState::kOpen)));
    RETURN_IF_ERROR(update.BindInt64(10, checkpoint.journal_through));
    if (checkpoint.map_check.empty()) {
      RETURN_IF_ERROR(update.BindNull(11));
    } else {
      RETURN_IF_ERROR(
          update.BindBlob(11, checkpoint.map_check.data(), checkpoint.map_check.size()));
    }
    RETURN_IF_ERROR(update.BindText(12, id));
    RETURN_IF_ERROR(update.Run());
    // The journal the checkpoint includes goes with it; a closed session keeps none.
    ASSIGN_OR_RETURN(Statement trim,
                     connection_.Prepare(absl::StrCat("DELETE FROM slam_journal WHERE session_id = ?",
                                                      close ? "" : " AND seq <= ?")));
    RETURN_IF_ERROR(trim.BindText(1, id));
    if (!close) RETURN_IF_ERROR(trim.BindInt64(2, checkpoint.journal_through));
    RETURN_IF_ERROR(trim.Run());
    return txn.Commit();
  }

  // Inside the checkpoint's transaction; the poses' seq are already checked.
  absl::Status InsertPosesLocked(const std::string& id,
                                 const std::vector<TrajectoryPoseRecord>& poses) {
    ASSIGN_OR_RETURN(Statement insert,
                     connection_.Prepare("INSERT INTO slam_trajectory "
                                         "(session_id, seq, stamp, x, y, theta, covariance, "
                                         "z, qx, qy, qz, qw) "
                                         "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)"));
    for (const TrajectoryPoseRecord& pose : poses) {
      insert.Reset();
      RETURN_IF_ERROR(insert.BindText(1, id));
      RETURN_IF_ERROR(insert.BindInt64(2, pose.seq));
      RETURN_IF_ERROR(insert.BindDouble(3, pose.stamp));
      RETURN_IF_ERROR(insert.BindDouble(4, pose.x));
      RETURN_IF_ERROR(insert.BindDouble(5, pose.y));
      RETURN_IF_ERROR(insert.BindDouble(6, pose.theta));
      const absl::string_view covariance = CovarianceBytes(pose);
      RETURN_IF_ERROR(insert.BindBlob(7, covariance.data(), covariance.size()));
      if (pose.pose3.has_value()) {
        RETURN_IF_ERROR(insert.BindDouble(8, pose.pose3->z));
        RETURN_IF_ERROR(insert.BindDouble(9, pose.pose3->qx));
        RETURN_IF_ERROR(insert.BindDouble(10, pose.pose3->qy));
        RETURN_IF_ERROR(insert.BindDouble(11, pose.pose3->qz));
        RETURN_IF_ERROR(insert.BindDouble(12, pose.pose3->qw));
      } else {
        for (int index = 8; index <= 12; ++index) RETURN_IF_ERROR(insert.BindNull(index));
      }
      RETURN_IF_ERROR(insert.Run());
    }
    return absl::OkStatus();
  }

  std::mutex mutex_;  // one connection, used by one thread at a time
  Connection connection_;
};

}  // namespace

absl::StatusOr<std::unique_ptr<SlamStore>> OpenSqliteSlamStore(const std::string& path) {
  ASSIGN_OR_RETURN(Connection connection, OpenMigratedDatabase(path));
  return std::unique_ptr<SlamStore>(new SqliteSlamStore(std::move(connection)));
}

}  // namespace waymark::storage
