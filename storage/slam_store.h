#ifndef WAYMARK_STORAGE_SLAM_STORE_H_
#define WAYMARK_STORAGE_SLAM_STORE_H_

// What the SLAM service persists: sessions (config, state, counters, the engine's checkpoint) and
// their trajectories. Rows and blobs only: the config is the service's serialized config message
// and the checkpoint is the engine's own versioned bytes, both opaque here. The interface is small
// so that a PostgreSQL implementation can stand beside the SQLite one (DESIGN.md): SLAM sessions
// pinned to servers by id, checkpoints in the shared database.

#include <array>
#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace waymark::storage {

enum class SlamSessionState { kOpen, kClosed };

// "open" / "closed", as stored.
const char* SlamSessionStateName(SlamSessionState state);

// Which server holds an open session (issue 19): when several servers share one database, a
// session is served by at most one of them at a time. The holder renews the lease well before it
// expires; a server that died stops renewing, and once the lease has expired another server may
// take the session over (from its last checkpoint). Times are the database's clock, so servers'
// clocks need not agree.
struct SlamLease {
  std::string owner;      // the holding server's id (random per server process); empty = nobody
  std::string address;    // where robots reach the holder (host:port), for redirects
  double expires_at = 0;  // unix seconds by the database's clock
};

struct SlamSessionRecord {
  std::string id;  // chosen by the caller (the service: 32 random hex digits)
  std::string robot_id;
  std::string name;
  std::string kind = "laser";  // "laser" or "visual"
  std::string config;          // opaque (the service stores its serialized config message)
  SlamSessionState state = SlamSessionState::kOpen;
  double created_at = 0;  // unix seconds; CreateSession fills created_at and updated_at
  double updated_at = 0;
  int64_t scans_processed = 0;
  int64_t map_revision = 0;
  int32_t segments = 0;
  // Newest stamps accepted per sensor at the last checkpoint (so a resumed session keeps
  // enforcing time order); unset = none yet.
  std::optional<double> last_scan_stamp;
  std::optional<double> last_odometry_stamp;
  std::string checkpoint;     // opaque engine state; empty = never checkpointed
  double checkpoint_at = 0;   // unix seconds; 0 = never checkpointed
  // The journal seq of the last accepted message the checkpoint includes (SlamJournalEntry);
  // journal rows after it are replayed on resume. 0 = none.
  int64_t journal_through = 0;
  // The final map's self-check, written with the closing checkpoint (opaque: the service's
  // serialized message); empty = none (an open session, or one without a map to check).
  std::string map_check;
  int64_t trajectory_length = 0;  // poses stored (read-only: filled by Get/List)
  SlamLease lease;                // read-only: filled by Get/List, set by AcquireLease
};

// The rest of a 3-D pose (visual sessions): with the record's x and y, the position (x, y, z)
// and the orientation as a unit quaternion.
struct Pose3Extra {
  double z = 0;
  double qx = 0, qy = 0, qz = 0, qw = 1;
};

// One pose of a session's trajectory. seq numbers the poses 0, 1, 2, ... in order.
struct TrajectoryPoseRecord {
  int64_t seq = 0;
  double stamp = 0;
  double x = 0;
  double y = 0;
  double theta = 0;                    // laser poses; 0 for 3-D poses
  std::array<double, 9> covariance{};  // 3x3 of (x, y, theta), row-major; zeros for 3-D poses
  std::optional<Pose3Extra> pose3;     // set for 3-D poses (stored NULL for laser rows)
};

// Everything a checkpoint writes, in one transaction: the engine state, the counters, and the
// trajectory poses not stored yet (their seq must continue the stored trajectory without a gap).
struct SlamCheckpoint {
  std::string state;  // opaque engine bytes
  int64_t scans_processed = 0;
  int64_t map_revision = 0;
  int32_t segments = 0;
  std::optional<double> last_scan_stamp;
  std::optional<double> last_odometry_stamp;
  std::vector<TrajectoryPoseRecord> new_poses;
  // The journal seq of the last message `state` includes: the journal rows up to it are deleted
  // in the same transaction (all of them when the session is closed). It never goes back.
  int64_t journal_through = 0;
  // Opaque (the service writes it when the session closes, SlamSessionRecord::map_check); empty =
  // none. Replaces the stored one.
  std::string map_check;
  // When set, the write is fenced by the lease: FAILED_PRECONDITION, and nothing written, unless
  // this owner holds the session's lease (expired or not: what matters is that no other server
  // has taken it over). A server that lost its lease can never overwrite its successor's work.
  std::string lease_owner;
};

// One accepted message of an open session, kept until a checkpoint includes it (issue 21: what
// the server answered survives a crash). seq numbers a session's accepted messages 1, 2, 3, ... in
// the order they were accepted; `message` is opaque (the service stores the client's SensorData).
struct SlamJournalEntry {
  std::string session_id;
  int64_t seq = 0;
  std::string message;
};

// Every mutating call is one transaction: it happens entirely or not at all.
// Errors: NOT_FOUND (unknown session), ALREADY_EXISTS (duplicate id), FAILED_PRECONDITION
// (checkpointing a closed session), INVALID_ARGUMENT (a trajectory seq that does not continue the
// stored one, non-finite numbers), INTERNAL (database failure, message carries the database's
// text), UNAVAILABLE (PostgreSQL unreachable: nothing was written), DATA_LOSS (a stored row that
// cannot be read back).
class SlamStore {
 public:
  virtual ~SlamStore() = default;

  // Inserts a new session; returns it with created_at/updated_at set.
  virtual absl::StatusOr<SlamSessionRecord> CreateSession(const SlamSessionRecord& session) = 0;
  // The session with its checkpoint bytes.
  virtual absl::StatusOr<SlamSessionRecord> GetSession(const std::string& id) = 0;
  // Sessions in creation order, all robots when `robot_id` is empty; without checkpoint bytes.
  virtual absl::StatusOr<std::vector<SlamSessionRecord>> ListSessions(
      const std::string& robot_id) = 0;
  virtual absl::StatusOr<int64_t> CountSessions(SlamSessionState state) = 0;
  // Writes a checkpoint of an open session (see SlamCheckpoint).
  virtual absl::Status WriteCheckpoint(const std::string& id, const SlamCheckpoint& checkpoint) = 0;
  // Writes the final checkpoint and marks the session closed, in one transaction.
  // FAILED_PRECONDITION when it is already closed.
  virtual absl::Status CloseSession(const std::string& id, const SlamCheckpoint& checkpoint) = 0;
  // Appends accepted messages of any sessions, in one transaction. Entries of a session that is
  // closed, unknown (deleted meanwhile) or, when `lease_owner` is set, leased by another owner are
  // skipped (that server's successor serves it from its own journal; the lease loop drops it
  // here). INVALID_ARGUMENT for a seq below 1; ALREADY_EXISTS for a seq stored before.
  virtual absl::Status AppendJournal(const std::vector<SlamJournalEntry>& entries,
                                     const std::string& lease_owner) = 0;
  // The session's journal after its checkpoint (seq > journal_through), in seq order.
  virtual absl::StatusOr<std::vector<SlamJournalEntry>> LoadJournal(const std::string& id) = 0;
  // The stored trajectory in seq order.
  virtual absl::StatusOr<std::vector<TrajectoryPoseRecord>> LoadTrajectory(
      const std::string& id) = 0;
  // Takes the lease of an open session for `owner` (or renews it: the same owner) for
  // `ttl_seconds` from now, unless another owner holds a lease that has not expired. Returns the
  // lease as it stands after the call: its owner is `owner` exactly when it was taken. Atomic
  // against every other server. NOT_FOUND (unknown session), FAILED_PRECONDITION (closed),
  // INVALID_ARGUMENT (empty owner, ttl not positive and finite).
  virtual absl::StatusOr<SlamLease> AcquireLease(const std::string& id, const std::string& owner,
                                                 const std::string& address,
                                                 double ttl_seconds) = 0;
  // Gives the lease up, if `owner` holds it, so that another server may take the session at
  // once (a server shutting down). OK when it does not hold it; NOT_FOUND (unknown session).
  virtual absl::Status ReleaseLease(const std::string& id, const std::string& owner) = 0;
  // Deletes the session (its row holds the checkpoint), its trajectory and journal, in one transaction,
  // whatever its state (the service decides whether an open session may go). Returns the session
  // as it was, without checkpoint bytes; its trajectory_length is the number of poses deleted.
  virtual absl::StatusOr<SlamSessionRecord> DeleteSession(const std::string& id) = 0;
};

// Opens (creating if needed) a SQLite file and migrates it to the current schema. The parent
// directory is created. ":memory:" gives a private in-memory database (tests). The file may be the
// one a CrossingStore uses: each store has its own connection (WAL lets them share it).
absl::StatusOr<std::unique_ptr<SlamStore>> OpenSqliteSlamStore(const std::string& path);

}  // namespace waymark::storage

#endif  // WAYMARK_STORAGE_SLAM_STORE_H_
