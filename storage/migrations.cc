#include "storage/migrations.h"

#include "absl/strings/str_cat.h"

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

}  // namespace waymark::storage
