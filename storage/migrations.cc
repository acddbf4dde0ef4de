#include "storage/migrations.h"

#include "absl/strings/str_cat.h"
#include "storage/store_util.h"

namespace waymark::storage {
namespace {

// v1: crossing databases, crossings, views with their features, clusters.
// - view and cluster use AUTOINCREMENT so that ids are never reused: increasing view ids are the
//   enrollment order, and a deleted id never comes back to alias a client's stale reference.
// - Feature blobs are raw little-endian arrays (float32 keypoints and hue histogram, uint8
//   descriptors); their counts are stored beside them so a truncated blob is detected on read.
// - Indexes cover every foreign key that a cascade or a per-database query walks. crossing(db_id)
//   and cluster_member(cluster_id) are already the leading columns of their UNIQUE / PRIMARY KEY.
constexpr absl::string_view kV1CrossingTables = R"sql(
CREATE TABLE crossing_db (
  id INTEGER PRIMARY KEY,
  name TEXT UNIQUE NOT NULL,
  params TEXT NOT NULL,
  created_at REAL NOT NULL
);

CREATE TABLE crossing (
  id INTEGER PRIMARY KEY,
  db_id INTEGER NOT NULL REFERENCES crossing_db(id) ON DELETE CASCADE,
  name TEXT NOT NULL,
  label TEXT NOT NULL DEFAULT '',
  UNIQUE (db_id, name)
);

CREATE TABLE view (
  id INTEGER PRIMARY KEY AUTOINCREMENT,
  crossing_id INTEGER NOT NULL REFERENCES crossing(id) ON DELETE CASCADE,
  heading_deg REAL NOT NULL,
  width INTEGER NOT NULL,
  height INTEGER NOT NULL,
  keypoint_count INTEGER NOT NULL,
  keypoints BLOB NOT NULL,
  descriptors BLOB NOT NULL,
  hue_hist BLOB NOT NULL,
  hue_bins INTEGER NOT NULL,
  format_version INTEGER NOT NULL,
  image BLOB,
  created_at REAL NOT NULL
);
CREATE INDEX view_crossing_id ON view(crossing_id);

CREATE TABLE cluster (
  id INTEGER PRIMARY KEY AUTOINCREMENT,
  db_id INTEGER NOT NULL REFERENCES crossing_db(id) ON DELETE CASCADE,
  center_view_id INTEGER NOT NULL REFERENCES view(id) ON DELETE CASCADE
);
CREATE INDEX cluster_db_id ON cluster(db_id);
CREATE INDEX cluster_center_view_id ON cluster(center_view_id);

CREATE TABLE cluster_member (
  cluster_id INTEGER NOT NULL REFERENCES cluster(id) ON DELETE CASCADE,
  view_id INTEGER NOT NULL REFERENCES view(id) ON DELETE CASCADE,
  PRIMARY KEY (cluster_id, view_id)
);
CREATE INDEX cluster_member_view_id ON cluster_member(view_id);
)sql";

// v2: laser SLAM sessions and their trajectories.
// - The session id is the service's random 128-bit hex string (TEXT primary key).
// - config is the service's serialized config message and checkpoint the engine's versioned state,
//   both opaque blobs. The counters beside them let ListSessions answer without the engine.
// - The trajectory is append-only: a periodic checkpoint inserts the poses since the previous one
//   (seq 0, 1, 2, ...) instead of rewriting them. covariance is 9 float64 (3x3, row-major).
constexpr absl::string_view kV2SlamTables = R"sql(
CREATE TABLE slam_session (
  id TEXT PRIMARY KEY,
  robot_id TEXT NOT NULL,
  name TEXT NOT NULL DEFAULT '',
  kind TEXT NOT NULL CHECK (kind IN ('laser')),
  config BLOB NOT NULL,
  state TEXT NOT NULL CHECK (state IN ('open', 'closed')),
  created_at REAL NOT NULL,
  updated_at REAL NOT NULL,
  scans_processed INTEGER NOT NULL DEFAULT 0,
  checkpoint BLOB,
  checkpoint_at REAL,
  map_revision INTEGER NOT NULL DEFAULT 0,
  segments INTEGER NOT NULL DEFAULT 0,
  last_scan_stamp REAL,
  last_odometry_stamp REAL
);
CREATE INDEX slam_session_robot_id ON slam_session(robot_id);
CREATE INDEX slam_session_state ON slam_session(state);

CREATE TABLE slam_trajectory (
  session_id TEXT NOT NULL REFERENCES slam_session(id) ON DELETE CASCADE,
  seq INTEGER NOT NULL,
  stamp REAL NOT NULL,
  x REAL NOT NULL,
  y REAL NOT NULL,
  theta REAL NOT NULL,
  covariance BLOB NOT NULL,
  PRIMARY KEY (session_id, seq)
) WITHOUT ROWID;
)sql";

// v3: per-robot bearer tokens (issue 6).
// - Only the SHA-256 of the secret is stored, so a copy of the database file cannot be used to
//   authenticate. The hash is UNIQUE: Authenticate looks a token up by it through the index.
// - name is the operator's label (e.g. the robot's name): revoke and list address tokens by it.
// - revoked_at is set instead of deleting the row, so list still shows what was revoked and when.
constexpr absl::string_view kV3Tokens = R"sql(
CREATE TABLE tokens (
  id INTEGER PRIMARY KEY,
  name TEXT NOT NULL UNIQUE,
  robot_id TEXT NOT NULL,
  role TEXT NOT NULL CHECK (role IN ('robot', 'mapper', 'admin')),
  secret_hash BLOB NOT NULL UNIQUE,
  created_at REAL NOT NULL,
  expires_at REAL,
  revoked_at REAL,
  last_used_at REAL
);
)sql";

// v4: visual odometry sessions (issue 7).
// - kind may be 'visual' (SQLite cannot alter a CHECK constraint, so slam_session is rebuilt).
// - Trajectory poses get the rest of a 3-D pose: x, y (the existing columns) with z and the unit
//   quaternion (qx, qy, qz, qw); NULL for laser rows, whose pose is (x, y, theta).
// The tables are rebuilt child first so that dropping the old session table cascades into
// nothing; RENAME then points the new trajectory's foreign key at the renamed session table.
constexpr absl::string_view kV4VisualSessions = R"sql(
CREATE TABLE slam_session_v4 (
  id TEXT PRIMARY KEY,
  robot_id TEXT NOT NULL,
  name TEXT NOT NULL DEFAULT '',
  kind TEXT NOT NULL CHECK (kind IN ('laser', 'visual')),
  config BLOB NOT NULL,
  state TEXT NOT NULL CHECK (state IN ('open', 'closed')),
  created_at REAL NOT NULL,
  updated_at REAL NOT NULL,
  scans_processed INTEGER NOT NULL DEFAULT 0,
  checkpoint BLOB,
  checkpoint_at REAL,
  map_revision INTEGER NOT NULL DEFAULT 0,
  segments INTEGER NOT NULL DEFAULT 0,
  last_scan_stamp REAL,
  last_odometry_stamp REAL
);
INSERT INTO slam_session_v4 (id, robot_id, name, kind, config, state, created_at, updated_at,
    scans_processed, checkpoint, checkpoint_at, map_revision, segments, last_scan_stamp,
    last_odometry_stamp)
  SELECT id, robot_id, name, kind, config, state, created_at, updated_at, scans_processed,
    checkpoint, checkpoint_at, map_revision, segments, last_scan_stamp, last_odometry_stamp
  FROM slam_session;
CREATE TABLE slam_trajectory_v4 (
  session_id TEXT NOT NULL REFERENCES slam_session_v4(id) ON DELETE CASCADE,
  seq INTEGER NOT NULL,
  stamp REAL NOT NULL,
  x REAL NOT NULL,
  y REAL NOT NULL,
  theta REAL NOT NULL,
  covariance BLOB NOT NULL,
  z REAL,
  qx REAL,
  qy REAL,
  qz REAL,
  qw REAL,
  PRIMARY KEY (session_id, seq)
) WITHOUT ROWID;
INSERT INTO slam_trajectory_v4 (session_id, seq, stamp, x, y, theta, covariance)
  SELECT session_id, seq, stamp, x, y, theta, covariance FROM slam_trajectory;
DROP TABLE slam_trajectory;
DROP TABLE slam_session;
ALTER TABLE slam_session_v4 RENAME TO slam_session;
ALTER TABLE slam_trajectory_v4 RENAME TO slam_trajectory;
CREATE INDEX slam_session_robot_id ON slam_session(robot_id);
CREATE INDEX slam_session_state ON slam_session(state);
)sql";

// v5: the SHA-256 of each crossing view's encoded image (issue 15), so that enrolling the same
// file again is recognised and skipped. NULL for views enrolled before: their image bytes are not
// known (stored images are optional), so they are "unknown", never a duplicate. Uniqueness is per
// database, which a column of `view` cannot express as a UNIQUE index (the database is one join
// away): the store checks it inside the insert's write transaction; the index makes that check a
// lookup.
constexpr absl::string_view kV5ViewContentHash = R"sql(
ALTER TABLE view ADD COLUMN content_sha256 BLOB;
CREATE INDEX view_content_sha256 ON view(content_sha256) WHERE content_sha256 IS NOT NULL;
)sql";

// v6: the capture position of each crossing view (issue 18): where in the crossing the view was
// taken, so one crossing may hold views from several positions at the same heading. Free text,
// '' (not tagged) for the views enrolled before, which is what they were.
constexpr absl::string_view kV6ViewPosition = R"sql(
ALTER TABLE view ADD COLUMN position TEXT NOT NULL DEFAULT '';
)sql";

// v7: the retrieval mode's global descriptor (issue 18). Each view keeps its grey image at working
// resolution (PNG, lossless) so its code can be computed again under a retrained vocabulary; views
// enrolled before have NULL and take no part in the global stage. One vocabulary per database,
// replaced whenever it is retrained, deleted with the database.
constexpr absl::string_view kV7GlobalDescriptor = R"sql(
ALTER TABLE view ADD COLUMN work_image BLOB;
CREATE TABLE crossing_vocabulary (
  db_id INTEGER PRIMARY KEY REFERENCES crossing_db(id) ON DELETE CASCADE,
  trained_views INTEGER NOT NULL,
  data BLOB NOT NULL,
  updated_at REAL NOT NULL
);
)sql";

// v8: each view's code under its database's vocabulary and the sample of its dense descriptors
// the vocabulary is retrained on, so that a server loads the global stage without computing
// anything again (both opaque to storage, NULL when the view has none).
constexpr absl::string_view kV8GlobalCodes = R"sql(
ALTER TABLE view ADD COLUMN global_code BLOB;
ALTER TABLE view ADD COLUMN global_sample BLOB;
)sql";

// v9: revisions of each crossing database (issue 19), so that servers sharing a database tell
// what another one changed: `revision` counts every write, `reload_revision` the writes that are
// not appends (crossing_store.h, DatabaseRecord).
constexpr absl::string_view kV9DatabaseRevisions = R"sql(
ALTER TABLE crossing_db ADD COLUMN revision INTEGER NOT NULL DEFAULT 0;
ALTER TABLE crossing_db ADD COLUMN reload_revision INTEGER NOT NULL DEFAULT 0;
)sql";

// v10: SLAM session leases (issue 19): when several servers share one database, each open session
// is served by one of them at a time (slam_store.h, SlamLease). The holder's id, the address robots
// reach it at, and when its lease expires (unix seconds); all NULL while nobody holds the session,
// which is what every session stored before was.
constexpr absl::string_view kV10SlamLeases = R"sql(
ALTER TABLE slam_session ADD COLUMN lease_owner TEXT;
ALTER TABLE slam_session ADD COLUMN lease_address TEXT;
ALTER TABLE slam_session ADD COLUMN lease_expires_at REAL;
)sql";

// v11: the SLAM journal (issue 21): every accepted message of an open session since its last
// checkpoint, so that a session resumed after a crash has everything the server answered
// (slam_store.h, SlamJournalEntry). `journal_through` is the last journal seq a checkpoint
// includes; the rows up to it are deleted with the checkpoint.
constexpr absl::string_view kV11SlamJournal = R"sql(
ALTER TABLE slam_session ADD COLUMN journal_through INTEGER NOT NULL DEFAULT 0;
CREATE TABLE slam_journal (
  session_id TEXT NOT NULL REFERENCES slam_session(id) ON DELETE CASCADE,
  seq INTEGER NOT NULL,
  message BLOB NOT NULL,
  PRIMARY KEY (session_id, seq)
);
)sql";

// v12: the final map's self-check of a closed SLAM session (issue 33), which ListSessions shows
// without loading the session (slam_store.h, SlamSessionRecord::map_check; opaque, NULL = none).
constexpr absl::string_view kV12SlamMapCheck = R"sql(
ALTER TABLE slam_session ADD COLUMN map_check BLOB;
)sql";

// v13: views with no heading (issue 34): a view taken facing an unknown way is stored with
// heading_known = 0 (heading_deg 0, meaning nothing) and answers its crossing only. Every view
// stored before had a heading.
constexpr absl::string_view kV13ViewHeadingKnown = R"sql(
ALTER TABLE view ADD COLUMN heading_known INTEGER NOT NULL DEFAULT 1;
)sql";

// v14: viewer tokens (issue 37): a role that may only watch (the live view, reads of every
// robot's SLAM sessions). SQLite cannot alter a CHECK constraint, so the table is rebuilt with the
// same columns and rows; nothing references it.
constexpr absl::string_view kV14ViewerTokens = R"sql(
CREATE TABLE tokens_v14 (
  id INTEGER PRIMARY KEY,
  name TEXT NOT NULL UNIQUE,
  robot_id TEXT NOT NULL,
  role TEXT NOT NULL CHECK (role IN ('robot', 'mapper', 'admin', 'viewer')),
  secret_hash BLOB NOT NULL UNIQUE,
  created_at REAL NOT NULL,
  expires_at REAL,
  revoked_at REAL,
  last_used_at REAL
);
INSERT INTO tokens_v14 (id, name, robot_id, role, secret_hash, created_at, expires_at, revoked_at,
                        last_used_at)
  SELECT id, name, robot_id, role, secret_hash, created_at, expires_at, revoked_at, last_used_at
  FROM tokens;
DROP TABLE tokens;
ALTER TABLE tokens_v14 RENAME TO tokens;
)sql";

// v15: maps shared by robots (issue 38, map_store.h): a named map with its revision, and its
// trajectories, one per SLAM session (a session is in one map at most: session_id is UNIQUE), in
// join order (ordinal), with where the session's frame lies in the map frame once tied in (the
// three tie columns, all NULL until then). Deleting a session or a map removes its trajectory
// rows; deleting a map never deletes a session.
constexpr absl::string_view kV15SlamMaps = R"sql(
CREATE TABLE slam_map (
  id INTEGER PRIMARY KEY AUTOINCREMENT,
  name TEXT NOT NULL UNIQUE,
  created_at REAL NOT NULL,
  updated_at REAL NOT NULL,
  revision INTEGER NOT NULL DEFAULT 0
);
CREATE TABLE slam_map_trajectory (
  map_id INTEGER NOT NULL REFERENCES slam_map(id) ON DELETE CASCADE,
  session_id TEXT NOT NULL UNIQUE REFERENCES slam_session(id) ON DELETE CASCADE,
  ordinal INTEGER NOT NULL,
  joined_at REAL NOT NULL,
  tie_x REAL,
  tie_y REAL,
  tie_theta REAL,
  PRIMARY KEY (map_id, ordinal)
);
)sql";

// v16: a map's lease (which server of a fleet ties and follows its trajectories, as a session's
// lease says which serves the session) and each trajectory's follow (the origin samples after its
// tie, the service's encoding), so that the follow survives a restart and passes to the next
// owner.
constexpr absl::string_view kV16SlamMapLeaseAndFollow = R"sql(
ALTER TABLE slam_map ADD COLUMN lease_owner TEXT;
ALTER TABLE slam_map ADD COLUMN lease_address TEXT;
ALTER TABLE slam_map ADD COLUMN lease_expires_at REAL;
ALTER TABLE slam_map_trajectory ADD COLUMN follow BLOB;
)sql";

// v17: a shared map's node feed (map_store.h, TrajectoryFeedUpdate): what the server a robot
// streams to publishes of its session's nodes for the map's owner, between checkpoints. One row a
// session (its nodes' poses) and one a node (its points, by scan); both go with the session.
constexpr absl::string_view kV17SlamMapFeed = R"sql(
CREATE TABLE slam_map_feed (
  session_id TEXT PRIMARY KEY REFERENCES slam_session(id) ON DELETE CASCADE,
  version INTEGER NOT NULL,
  scans_processed INTEGER NOT NULL,
  updated_at REAL NOT NULL,
  poses BLOB NOT NULL
);
CREATE TABLE slam_map_feed_node (
  session_id TEXT NOT NULL REFERENCES slam_session(id) ON DELETE CASCADE,
  scan INTEGER NOT NULL,
  points BLOB NOT NULL,
  PRIMARY KEY (session_id, scan)
);
)sql";

absl::Status TooNewError(sqlite::Connection& connection, int version, int latest) {
  return absl::FailedPreconditionError(absl::StrCat(
      "database \"", connection.path(), "\" has schema version ", version,
      " but this build only knows versions up to ", latest,
      "; it was written by a newer Waymark: upgrade Waymark or use another database file"));
}

}  // namespace

const std::vector<absl::string_view>& SchemaMigrations() {
  // Append new steps at the end (e.g. the SLAM session tables); never edit a released one.
  static const auto* const kSteps = new std::vector<absl::string_view>{
      kV1CrossingTables,
      kV2SlamTables,
      kV3Tokens,
      kV4VisualSessions,
      kV5ViewContentHash,
      kV6ViewPosition,
      kV7GlobalDescriptor,
      kV8GlobalCodes,
      kV9DatabaseRevisions,
      kV10SlamLeases,
      kV11SlamJournal,
      kV12SlamMapCheck,
      kV13ViewHeadingKnown,
      kV14ViewerTokens,
      kV15SlamMaps,
      kV16SlamMapLeaseAndFollow,
      kV17SlamMapFeed,
  };
  return *kSteps;
}

int CurrentSchemaVersion() { return static_cast<int>(SchemaMigrations().size()); }

absl::StatusOr<int> ReadSchemaVersion(sqlite::Connection& connection) {
  absl::StatusOr<sqlite::Statement> stmt = connection.Prepare("PRAGMA user_version");
  if (!stmt.ok()) return stmt.status();
  absl::StatusOr<sqlite::StepResult> step = stmt->Step();
  if (!step.ok()) return step.status();
  if (*step != sqlite::StepResult::kRow) return absl::InternalError("PRAGMA user_version: no row");
  return stmt->ColumnInt32(0);
}

absl::Status ApplyMigrations(sqlite::Connection& connection,
                             const std::vector<absl::string_view>& steps) {
  const int latest = static_cast<int>(steps.size());
  // Most opens find the file up to date: check without taking the write lock.
  absl::StatusOr<int> version = ReadSchemaVersion(connection);
  if (!version.ok()) return version.status();
  while (true) {
    if (*version > latest) return TooNewError(connection, *version, latest);
    if (*version == latest) return absl::OkStatus();

    absl::StatusOr<sqlite::Transaction> txn = sqlite::Transaction::Begin(connection);
    if (!txn.ok()) return txn.status();
    // Re-read under the write lock: another process may have migrated since our last look.
    version = ReadSchemaVersion(connection);
    if (!version.ok()) return version.status();
    if (*version >= latest) continue;  // the transaction rolls back (a no-op); loop re-checks

    const int target = *version + 1;
    if (absl::Status s = connection.Exec(steps[target - 1]); !s.ok()) {
      return absl::Status(
          s.code(), absl::StrCat("schema migration to version ", target, " failed: ", s.message()));
    }
    // PRAGMA takes no parameters; `target` is our own integer, so formatting it in is safe.
    if (absl::Status s = connection.Exec(absl::StrCat("PRAGMA user_version = ", target)); !s.ok()) {
      return s;
    }
    if (absl::Status s = txn->Commit(); !s.ok()) return s;
    *version = target;
  }
}

absl::Status MigrateSchema(sqlite::Connection& connection) {
  return ApplyMigrations(connection, SchemaMigrations());
}

absl::StatusOr<sqlite::Connection> OpenMigratedDatabase(const std::string& path) {
  if (absl::Status s = EnsureParentDirectory(path); !s.ok()) return s;
  absl::StatusOr<sqlite::Connection> connection = sqlite::Connection::Open(path);
  if (!connection.ok()) return connection.status();
  if (absl::Status s = MigrateSchema(*connection); !s.ok()) return s;
  return connection;
}

}  // namespace waymark::storage
