#ifndef WAYMARK_STORAGE_SLAM_RECORDS_H_
#define WAYMARK_STORAGE_SLAM_RECORDS_H_

// What the SQLite and PostgreSQL SlamStores share: checking what a caller asks to store, the
// columns they select and how a row becomes a record, the covariance blob's layout and the error
// messages. Written once, so that both backends accept, refuse and report exactly the same things;
// each store keeps only its SQL and its transactions.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "storage/slam_store.h"
#include "storage/stored_row.h"

namespace waymark::storage {

// A pose's covariance as stored: its 9 doubles, row-major, as raw bytes in host (little-endian)
// order.
inline constexpr size_t kCovarianceBytes = 9 * sizeof(double);
absl::string_view CovarianceBytes(const TrajectoryPoseRecord& pose);

// The record CreateSession inserts: `session` with created_at and updated_at set to now and the
// fields a new session cannot have (checkpoint, trajectory) cleared. INVALID_ARGUMENT for an
// empty id or an unknown kind.
absl::StatusOr<SlamSessionRecord> NewSlamSession(const SlamSessionRecord& session);

// INVALID_ARGUMENT for a checkpoint that cannot be stored as given: a non-finite stamp or pose, a
// negative counter. Checked before any transaction starts.
absl::Status CheckSlamCheckpoint(const SlamCheckpoint& checkpoint);

// INVALID_ARGUMENT for journal entries that cannot be stored: an empty session id, a seq below 1.
absl::Status CheckJournalEntries(const std::vector<SlamJournalEntry>& entries);

// Whether `checkpoint` may be written to `session` as read inside the checkpoint's transaction
// (after the session's row is locked, so that no other server can take the lease in between):
// FAILED_PRECONDITION when the session is closed or the checkpoint is fenced by a lease this owner
// no longer holds (CheckLeaseFence), INVALID_ARGUMENT when the new poses' seq do not continue its
// stored trajectory (no gap, no repeat) or its journal_through is behind the stored one.
absl::Status CheckCheckpointApplies(const SlamSessionRecord& session,
                                    const SlamCheckpoint& checkpoint);

// The lease fence alone: OK for an unfenced checkpoint (empty lease_owner) or when lease_owner
// holds `session`'s lease, expired or not; FAILED_PRECONDITION naming the holder's address else.
absl::Status CheckLeaseFence(const SlamSessionRecord& session, const SlamCheckpoint& checkpoint);

// INVALID_ARGUMENT for an AcquireLease that cannot be granted to anyone: an empty owner, a ttl
// that is not positive and finite. Checked before any transaction starts.
absl::Status CheckLeaseRequest(absl::string_view owner, double ttl_seconds);

// The lease `session` (as read inside the lease's transaction, its row locked) holds once `owner`
// has asked for it at `now` (the database's clock): `owner`'s, until now + ttl, when nobody holds
// it, `owner` already does (a renewal) or the holder's lease expired before `now`; the stored one,
// unchanged, else. The store writes it back exactly when its owner is `owner`.
// FAILED_PRECONDITION when the session is closed.
absl::StatusOr<SlamLease> LeaseAfterAcquire(const SlamSessionRecord& session,
                                            absl::string_view owner, absl::string_view address,
                                            double ttl_seconds, double now);
// The same rule for any leased row (a session's, a map's: map_store.h) holding `held`.
SlamLease LeaseAfter(const SlamLease& held, absl::string_view owner, absl::string_view address,
                     double ttl_seconds, double now);

// The SET list that gives a session's lease up (ReleaseLease, and CloseSession: a closed session
// has no holder), in both backends' syntax.
inline constexpr absl::string_view kClearSlamLease =
    "lease_owner = NULL, lease_address = NULL, lease_expires_at = NULL";

absl::Status SlamSessionNotFound(absl::string_view id);
absl::Status SlamSessionAlreadyExists(absl::string_view id);

// A SELECT of sessions (alias `s`) in the column order ReadSlamSessionRow reads, with the
// trajectory length counted; `where` (in the backend's placeholder syntax) follows the FROM. The
// checkpoint bytes only when asked for (they can be large; a list does not need them).
std::string SelectSlamSessions(bool with_checkpoint, absl::string_view where);
// DATA_LOSS for a state that is neither open nor closed.
absl::StatusOr<SlamSessionRecord> ReadSlamSessionRow(const StoredRow& row);

// slam_trajectory's columns in the order ReadTrajectoryPoseRow reads.
inline constexpr absl::string_view kTrajectoryColumns =
    "seq, stamp, x, y, theta, covariance, z, qx, qy, qz, qw";
// Pose `index` of session `id`'s trajectory, read in seq order. DATA_LOSS when its seq is not
// `index` (a pose is missing), its covariance blob has the wrong size, or it has a z but not its
// whole orientation.
absl::StatusOr<TrajectoryPoseRecord> ReadTrajectoryPoseRow(absl::string_view id, int64_t index,
                                                           const StoredRow& row);

}  // namespace waymark::storage

#endif  // WAYMARK_STORAGE_SLAM_RECORDS_H_
