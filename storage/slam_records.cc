#include "storage/slam_records.h"

#include <cmath>
#include <cstring>
#include <optional>

#include "absl/strings/str_cat.h"
#include "storage/status_macros.h"
#include "storage/store_util.h"

namespace waymark::storage {

const char* SlamSessionStateName(SlamSessionState state) {
  return state == SlamSessionState::kClosed ? "closed" : "open";
}

namespace {

bool IsFinitePose(const TrajectoryPoseRecord& pose) {
  const bool finite3 =
      !pose.pose3.has_value() || (std::isfinite(pose.pose3->z) && std::isfinite(pose.pose3->qx) &&
                                  std::isfinite(pose.pose3->qy) && std::isfinite(pose.pose3->qz) &&
                                  std::isfinite(pose.pose3->qw));
  return std::isfinite(pose.stamp) && std::isfinite(pose.x) && std::isfinite(pose.y) &&
         std::isfinite(pose.theta) && finite3;
}

std::string PoseContext(absl::string_view id, int64_t seq) {
  return absl::StrCat("SLAM session ", Quoted(id), ": trajectory pose ", seq);
}

absl::Status SlamSessionClosed(absl::string_view id) {
  return absl::FailedPreconditionError(absl::StrCat("SLAM session ", Quoted(id), " is closed"));
}

}  // namespace

absl::string_view CovarianceBytes(const TrajectoryPoseRecord& pose) {
  return absl::string_view(reinterpret_cast<const char*>(pose.covariance.data()), kCovarianceBytes);
}

absl::StatusOr<SlamSessionRecord> NewSlamSession(const SlamSessionRecord& session) {
  if (session.id.empty()) return absl::InvalidArgumentError("SLAM session id is empty");
  if (session.kind != "laser" && session.kind != "visual") {
    return absl::InvalidArgumentError(absl::StrCat("SLAM session kind ", Quoted(session.kind),
                                                   " is not supported (laser, visual)"));
  }
  SlamSessionRecord created = session;
  created.created_at = created.updated_at = NowSeconds();
  created.checkpoint.clear();
  created.checkpoint_at = 0;
  created.trajectory_length = 0;
  return created;
}

// SQLite stores NaN as NULL, which a NOT NULL column rejects with an opaque error, and PostgreSQL
// would store it: either way say what is wrong instead.
absl::Status CheckSlamCheckpoint(const SlamCheckpoint& checkpoint) {
  for (const auto& stamp : {checkpoint.last_scan_stamp, checkpoint.last_odometry_stamp}) {
    if (stamp.has_value() && !std::isfinite(*stamp)) {
      return absl::InvalidArgumentError("checkpoint sensor stamp is not a finite number");
    }
  }
  for (const TrajectoryPoseRecord& pose : checkpoint.new_poses) {
    if (!IsFinitePose(pose)) {
      return absl::InvalidArgumentError(
          absl::StrCat("trajectory pose ", pose.seq, " has a non-finite stamp or pose"));
    }
  }
  if (checkpoint.scans_processed < 0 || checkpoint.map_revision < 0 || checkpoint.segments < 0 ||
      checkpoint.journal_through < 0) {
    return absl::InvalidArgumentError("checkpoint counters must be >= 0");
  }
  return absl::OkStatus();
}

absl::Status CheckJournalEntries(const std::vector<SlamJournalEntry>& entries) {
  for (const SlamJournalEntry& entry : entries) {
    if (entry.session_id.empty()) {
      return absl::InvalidArgumentError("journal entry without a session id");
    }
    if (entry.seq < 1) {
      return absl::InvalidArgumentError(absl::StrCat("SLAM session ", Quoted(entry.session_id),
                                                     ": journal seq ", entry.seq, " is below 1"));
    }
  }
  return absl::OkStatus();
}

absl::Status CheckCheckpointApplies(const SlamSessionRecord& session,
                                    const SlamCheckpoint& checkpoint) {
  if (session.state == SlamSessionState::kClosed) return SlamSessionClosed(session.id);
  // Before the seq check: a server that lost its lease is usually also behind its successor's
  // trajectory, and what it must be told is that it lost the session.
  RETURN_IF_ERROR(CheckLeaseFence(session, checkpoint));
  if (checkpoint.journal_through < session.journal_through) {
    return absl::InvalidArgumentError(absl::StrCat(
        "SLAM session ", Quoted(session.id), ": checkpoint includes the journal up to ",
        checkpoint.journal_through, " but the stored one already up to ", session.journal_through));
  }
  int64_t next_seq = session.trajectory_length;
  for (const TrajectoryPoseRecord& pose : checkpoint.new_poses) {
    if (pose.seq != next_seq) {
      return absl::InvalidArgumentError(
          absl::StrCat("SLAM session ", Quoted(session.id), ": trajectory pose seq ", pose.seq,
                       " does not continue the stored trajectory (next seq is ", next_seq, ")"));
    }
    ++next_seq;
  }
  return absl::OkStatus();
}

absl::Status CheckLeaseFence(const SlamSessionRecord& session, const SlamCheckpoint& checkpoint) {
  if (checkpoint.lease_owner.empty() || session.lease.owner == checkpoint.lease_owner) {
    return absl::OkStatus();
  }
  if (session.lease.owner.empty()) {
    // Released (or never taken): nobody took it over yet, but this server gave it up or never had
    // it, and another may take it at any moment; its writes must not land.
    return absl::FailedPreconditionError(
        absl::StrCat("SLAM session ", Quoted(session.id),
                     " is held by no server; this server's lease was lost"));
  }
  return absl::FailedPreconditionError(absl::StrCat(
      "SLAM session ", Quoted(session.id), " is held by another server (", session.lease.address,
      ") since it took the session over; this server's lease was lost"));
}

absl::Status CheckLeaseRequest(absl::string_view owner, double ttl_seconds) {
  if (owner.empty()) return absl::InvalidArgumentError("SLAM session lease owner is empty");
  if (!std::isfinite(ttl_seconds) || ttl_seconds <= 0) {
    return absl::InvalidArgumentError(absl::StrCat("SLAM session lease ttl ", ttl_seconds,
                                                   " s is not a positive finite number"));
  }
  return absl::OkStatus();
}

absl::StatusOr<SlamLease> LeaseAfterAcquire(const SlamSessionRecord& session,
                                            absl::string_view owner, absl::string_view address,
                                            double ttl_seconds, double now) {
  if (session.state == SlamSessionState::kClosed) return SlamSessionClosed(session.id);
  return LeaseAfter(session.lease, owner, address, ttl_seconds, now);
}

SlamLease LeaseAfter(const SlamLease& held, absl::string_view owner, absl::string_view address,
                     double ttl_seconds, double now) {
  if (!held.owner.empty() && held.owner != owner && held.expires_at >= now) return held;
  return SlamLease{std::string(owner), std::string(address), now + ttl_seconds};
}

absl::Status SlamSessionNotFound(absl::string_view id) {
  return absl::NotFoundError(absl::StrCat("SLAM session ", Quoted(id), " not found"));
}

absl::Status SlamSessionAlreadyExists(absl::string_view id) {
  return absl::AlreadyExistsError(absl::StrCat("SLAM session ", Quoted(id), " already exists"));
}

std::string SelectSlamSessions(bool with_checkpoint, absl::string_view where) {
  return absl::StrCat(
      "SELECT s.id, s.robot_id, s.name, s.kind, s.config, s.state, s.created_at, s.updated_at, "
      "s.scans_processed, s.map_revision, s.segments, s.last_scan_stamp, s.last_odometry_stamp, "
      "s.checkpoint_at, (SELECT COUNT(*) FROM slam_trajectory t WHERE t.session_id = s.id), "
      "s.lease_owner, s.lease_address, s.lease_expires_at, s.journal_through, ",
      with_checkpoint ? "s.checkpoint" : "NULL", ", s.map_check FROM slam_session s ", where);
}

absl::StatusOr<SlamSessionRecord> ReadSlamSessionRow(const StoredRow& row) {
  SlamSessionRecord session;
  session.id = row.Text(0);
  session.robot_id = row.Text(1);
  session.name = row.Text(2);
  session.kind = row.Text(3);
  session.config = row.Text(4);
  const std::string state = row.Text(5);
  if (state == SlamSessionStateName(SlamSessionState::kOpen)) {
    session.state = SlamSessionState::kOpen;
  } else if (state == SlamSessionStateName(SlamSessionState::kClosed)) {
    session.state = SlamSessionState::kClosed;
  } else {
    return absl::DataLossError(
        absl::StrCat("SLAM session ", Quoted(session.id), " has unknown state ", Quoted(state)));
  }
  session.created_at = row.Double(6);
  session.updated_at = row.Double(7);
  session.scans_processed = row.Int64(8);
  session.map_revision = row.Int64(9);
  session.segments = row.Int32(10);
  session.last_scan_stamp = row.OptionalDouble(11);
  session.last_odometry_stamp = row.OptionalDouble(12);
  session.checkpoint_at = row.OptionalDouble(13).value_or(0.0);
  session.trajectory_length = row.Int64(14);
  // All NULL while nobody holds the session: an empty lease.
  session.lease.owner = row.Text(15);
  session.lease.address = row.Text(16);
  session.lease.expires_at = row.OptionalDouble(17).value_or(0.0);
  session.journal_through = row.Int64(18);
  session.checkpoint = row.Text(19);
  session.map_check = row.Text(20);
  return session;
}

absl::StatusOr<TrajectoryPoseRecord> ReadTrajectoryPoseRow(absl::string_view id, int64_t index,
                                                           const StoredRow& row) {
  TrajectoryPoseRecord pose;
  pose.seq = row.Int64(0);
  if (pose.seq != index) {
    return absl::DataLossError(
        absl::StrCat(PoseContext(id, index), " is missing (found seq ", pose.seq, ")"));
  }
  pose.stamp = row.Double(1);
  pose.x = row.Double(2);
  pose.y = row.Double(3);
  pose.theta = row.Double(4);
  const absl::string_view covariance = row.Bytes(5);
  if (covariance.size() != kCovarianceBytes) {
    return absl::DataLossError(absl::StrCat(PoseContext(id, pose.seq), " covariance blob has ",
                                            covariance.size(), " bytes, expected ",
                                            kCovarianceBytes));
  }
  std::memcpy(pose.covariance.data(), covariance.data(), kCovarianceBytes);
  // Laser rows hold NULL from z on; a 3-D row holds all five.
  if (!row.IsNull(6)) {
    for (int column = 7; column <= 10; ++column) {
      if (row.IsNull(column)) {
        return absl::DataLossError(
            absl::StrCat(PoseContext(id, pose.seq), " has z but not its whole orientation"));
      }
    }
    pose.pose3 =
        Pose3Extra{row.Double(6), row.Double(7), row.Double(8), row.Double(9), row.Double(10)};
  }
  return pose;
}

}  // namespace waymark::storage
