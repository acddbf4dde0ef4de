// SlamStore on SQLite: one connection behind a mutex, one transaction per mutating call.

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <filesystem>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <system_error>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "storage/migrations.h"
#include "storage/slam_store.h"
#include "storage/sqlite.h"
#include "storage/store_util.h"
#include "storage/status_macros.h"

namespace waymark::storage {

const char* SlamSessionStateName(SlamSessionState state) {
  return state == SlamSessionState::kClosed ? "closed" : "open";
}

namespace {

using sqlite::Connection;
using sqlite::Statement;
using sqlite::StepResult;
using sqlite::Transaction;
using sqlite::UniqueViolation;

constexpr size_t kCovarianceBytes = 9 * sizeof(double);

// SQLite stores NaN as NULL, which a NOT NULL column rejects with an opaque error: say what is
// wrong instead.
absl::Status CheckFinite(const SlamCheckpoint& checkpoint) {
  for (const auto& stamp : {checkpoint.last_scan_stamp, checkpoint.last_odometry_stamp}) {
    if (stamp.has_value() && !std::isfinite(*stamp)) {
      return absl::InvalidArgumentError("checkpoint sensor stamp is not a finite number");
    }
  }
  for (const TrajectoryPoseRecord& pose : checkpoint.new_poses) {
    const bool finite3 =
        !pose.pose3.has_value() ||
        (std::isfinite(pose.pose3->z) && std::isfinite(pose.pose3->qx) &&
         std::isfinite(pose.pose3->qy) && std::isfinite(pose.pose3->qz) &&
         std::isfinite(pose.pose3->qw));
    if (!std::isfinite(pose.stamp) || !std::isfinite(pose.x) || !std::isfinite(pose.y) ||
        !std::isfinite(pose.theta) || !finite3) {
      return absl::InvalidArgumentError(
          absl::StrCat("trajectory pose ", pose.seq, " has a non-finite stamp or pose"));
    }
  }
  if (checkpoint.scans_processed < 0 || checkpoint.map_revision < 0 || checkpoint.segments < 0) {
    return absl::InvalidArgumentError("checkpoint counters must be >= 0");
  }
  return absl::OkStatus();
}

// Columns of kSelectSession, in order; `checkpoint` only when asked for.
std::string SelectSessions(bool with_checkpoint, const std::string& where) {
  return absl::StrCat(
      "SELECT s.id, s.robot_id, s.name, s.kind, s.config, s.state, s.created_at, s.updated_at, "
      "s.scans_processed, s.map_revision, s.segments, s.last_scan_stamp, s.last_odometry_stamp, "
      "s.checkpoint_at, (SELECT COUNT(*) FROM slam_trajectory t WHERE t.session_id = s.id), ",
      with_checkpoint ? "s.checkpoint" : "NULL", " FROM slam_session s ", where);
}

absl::StatusOr<SlamSessionRecord> ReadSessionRow(const Statement& row) {
  SlamSessionRecord session;
  session.id = row.ColumnText(0);
  session.robot_id = row.ColumnText(1);
  session.name = row.ColumnText(2);
  session.kind = row.ColumnText(3);
  absl::string_view config = row.ColumnBlobView(4);
  session.config.assign(config.data(), config.size());
  const std::string state = row.ColumnText(5);
  if (state == "open") {
    session.state = SlamSessionState::kOpen;
  } else if (state == "closed") {
    session.state = SlamSessionState::kClosed;
  } else {
    return absl::DataLossError(
        absl::StrCat("SLAM session ", Quoted(session.id), " has unknown state ", Quoted(state)));
  }
  session.created_at = row.ColumnDouble(6);
  session.updated_at = row.ColumnDouble(7);
  session.scans_processed = row.ColumnInt64(8);
  session.map_revision = row.ColumnInt64(9);
  session.segments = row.ColumnInt32(10);
  session.last_scan_stamp = row.ColumnOptionalDouble(11);
  session.last_odometry_stamp = row.ColumnOptionalDouble(12);
  session.checkpoint_at = row.ColumnIsNull(13) ? 0.0 : row.ColumnDouble(13);
  session.trajectory_length = row.ColumnInt64(14);
  absl::string_view checkpoint = row.ColumnBlobView(15);
  session.checkpoint.assign(checkpoint.data(), checkpoint.size());
  return session;
}

class SqliteSlamStore final : public SlamStore {
 public:
  explicit SqliteSlamStore(Connection connection) : connection_(std::move(connection)) {}

  absl::StatusOr<SlamSessionRecord> CreateSession(const SlamSessionRecord& session) override {
    if (session.id.empty()) return absl::InvalidArgumentError("SLAM session id is empty");
    if (session.kind != "laser" && session.kind != "visual") {
      return absl::InvalidArgumentError(absl::StrCat(
          "SLAM session kind ", Quoted(session.kind), " is not supported (laser, visual)"));
    }
    std::lock_guard<std::mutex> lock(mutex_);
    SlamSessionRecord created = session;
    created.created_at = created.updated_at = NowSeconds();
    created.checkpoint.clear();
    created.checkpoint_at = 0;
    created.trajectory_length = 0;
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
    if (absl::IsAlreadyExists(run)) {
      return absl::AlreadyExistsError(
          absl::StrCat("SLAM session ", Quoted(created.id), " already exists"));
    }
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
                     connection_.Prepare(SelectSessions(
                         false, "WHERE (?1 = '' OR s.robot_id = ?1) ORDER BY s.created_at, s.id")));
    RETURN_IF_ERROR(stmt.BindText(1, robot_id));
    std::vector<SlamSessionRecord> sessions;
    while (true) {
      ASSIGN_OR_RETURN(StepResult step, stmt.Step());
      if (step == StepResult::kDone) break;
      ASSIGN_OR_RETURN(SlamSessionRecord session, ReadSessionRow(stmt));
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

  absl::StatusOr<std::vector<TrajectoryPoseRecord>> LoadTrajectory(const std::string& id) override {
    std::lock_guard<std::mutex> lock(mutex_);
    ASSIGN_OR_RETURN(SlamSessionRecord session, GetSessionLocked(id, false));
    ASSIGN_OR_RETURN(Statement stmt,
                     connection_.Prepare("SELECT seq, stamp, x, y, theta, covariance, "
                                         "z, qx, qy, qz, qw "
                                         "FROM slam_trajectory WHERE session_id = ? ORDER BY seq"));
    RETURN_IF_ERROR(stmt.BindText(1, id));
    std::vector<TrajectoryPoseRecord> poses;
    poses.reserve(static_cast<size_t>(session.trajectory_length));
    while (true) {
      ASSIGN_OR_RETURN(StepResult step, stmt.Step());
      if (step == StepResult::kDone) break;
      TrajectoryPoseRecord pose;
      pose.seq = stmt.ColumnInt64(0);
      if (pose.seq != static_cast<int64_t>(poses.size())) {
        return absl::DataLossError(absl::StrCat("SLAM session ", Quoted(id), ": trajectory pose ",
                                                poses.size(), " is missing (found seq ", pose.seq,
                                                ")"));
      }
      pose.stamp = stmt.ColumnDouble(1);
      pose.x = stmt.ColumnDouble(2);
      pose.y = stmt.ColumnDouble(3);
      pose.theta = stmt.ColumnDouble(4);
      absl::string_view covariance = stmt.ColumnBlobView(5);
      if (covariance.size() != kCovarianceBytes) {
        return absl::DataLossError(absl::StrCat("SLAM session ", Quoted(id), ": trajectory pose ",
                                                pose.seq, " covariance blob has ",
                                                covariance.size(), " bytes, expected ",
                                                kCovarianceBytes));
      }
      std::memcpy(pose.covariance.data(), covariance.data(), kCovarianceBytes);
      if (!stmt.ColumnIsNull(6)) {
        for (int column = 7; column <= 10; ++column) {
          if (stmt.ColumnIsNull(column)) {
            return absl::DataLossError(absl::StrCat("SLAM session ", Quoted(id),
                                                    ": trajectory pose ", pose.seq,
                                                    " has z but not its whole orientation"));
          }
        }
        pose.pose3 = Pose3Extra{stmt.ColumnDouble(6), stmt.ColumnDouble(7), stmt.ColumnDouble(8),
                                stmt.ColumnDouble(9), stmt.ColumnDouble(10)};
      }
      poses.push_back(pose);
    }
    return poses;
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
  static absl::Status NotFound(const std::string& id) {
    return absl::NotFoundError(absl::StrCat("SLAM session ", Quoted(id), " not found"));
  }

  absl::StatusOr<SlamSessionRecord> GetSessionLocked(const std::string& id, bool with_checkpoint) {
    ASSIGN_OR_RETURN(Statement stmt,
                     connection_.Prepare(SelectSessions(with_checkpoint, "WHERE s.id = ?")));
    RETURN_IF_ERROR(stmt.BindText(1, id));
    ASSIGN_OR_RETURN(StepResult step, stmt.Step());
    if (step == StepResult::kDone) return NotFound(id);
    return ReadSessionRow(stmt);
  }

  absl::Status CheckpointLocked(const std::string& id, const SlamCheckpoint& checkpoint,
                                bool close) {
    RETURN_IF_ERROR(CheckFinite(checkpoint));
    ASSIGN_OR_RETURN(Transaction txn, Transaction::Begin(connection_));
    ASSIGN_OR_RETURN(SlamSessionRecord session, GetSessionLocked(id, false));
    if (session.state == SlamSessionState::kClosed) {
      return absl::FailedPreconditionError(
          absl::StrCat("SLAM session ", Quoted(id), " is closed"));
    }
    int64_t next_seq = session.trajectory_length;
    ASSIGN_OR_RETURN(Statement insert,
                     connection_.Prepare("INSERT INTO slam_trajectory "
                                         "(session_id, seq, stamp, x, y, theta, covariance, "
                                         "z, qx, qy, qz, qw) "
                                         "VALUES (?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?, ?)"));
    for (const TrajectoryPoseRecord& pose : checkpoint.new_poses) {
      if (pose.seq != next_seq) {
        return absl::InvalidArgumentError(absl::StrCat(
            "SLAM session ", Quoted(id), ": trajectory pose seq ", pose.seq,
            " does not continue the stored trajectory (next seq is ", next_seq, ")"));
      }
      insert.Reset();
      RETURN_IF_ERROR(insert.BindText(1, id));
      RETURN_IF_ERROR(insert.BindInt64(2, pose.seq));
      RETURN_IF_ERROR(insert.BindDouble(3, pose.stamp));
      RETURN_IF_ERROR(insert.BindDouble(4, pose.x));
      RETURN_IF_ERROR(insert.BindDouble(5, pose.y));
      RETURN_IF_ERROR(insert.BindDouble(6, pose.theta));
      RETURN_IF_ERROR(insert.BindBlob(7, pose.covariance.data(), kCovarianceBytes));
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
      ++next_seq;
    }
    ASSIGN_OR_RETURN(Statement update,
                     connection_.Prepare(
                         "UPDATE slam_session SET checkpoint = ?, checkpoint_at = ?, "
                         "updated_at = ?, scans_processed = ?, map_revision = ?, segments = ?, "
                         "last_scan_stamp = ?, last_odometry_stamp = ?, state = ? WHERE id = ?"));
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
    RETURN_IF_ERROR(update.BindText(10, id));
    RETURN_IF_ERROR(update.Run());
    return txn.Commit();
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
