#ifndef WAYMARK_STORAGE_MIGRATIONS_H_
#define WAYMARK_STORAGE_MIGRATIONS_H_

// Schema migrations tracked by `PRAGMA user_version`. The file is shared by every store (crossings,
// later SLAM sessions), so there is one ordered list of steps for the whole file: step i takes the
// schema from version i to i + 1. Steps are append-only; a released step is never edited.

#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "storage/sqlite.h"

namespace waymark::storage {

// The waymark schema's steps, oldest first.
const std::vector<absl::string_view>& SchemaMigrations();

// The version a fully migrated file has: SchemaMigrations().size().
int CurrentSchemaVersion();

// Reads `PRAGMA user_version`.
absl::StatusOr<int> ReadSchemaVersion(sqlite::Connection& connection);

// Applies the steps the file has not seen yet, each in its own transaction that also bumps
// user_version, so a crash leaves the file at a consistent version. Safe against another process
// migrating the same file at the same time (the version is re-read under the write lock).
// FAILED_PRECONDITION when the file is newer than `steps` (written by a newer build).
absl::Status ApplyMigrations(sqlite::Connection& connection,
                             const std::vector<absl::string_view>& steps);

// ApplyMigrations(connection, SchemaMigrations()).
absl::Status MigrateSchema(sqlite::Connection& connection);

// Opens (creating it and its parent directory when missing) the database file at `path`, or an
// in-memory database for "" / ":memory:", and migrates it to the current schema. Every store opens
// its file through this.
absl::StatusOr<sqlite::Connection> OpenMigratedDatabase(const std::string& path);

}  // namespace waymark::storage

#endif  // WAYMARK_STORAGE_MIGRATIONS_H_
