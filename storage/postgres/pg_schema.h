#ifndef WAYMARK_STORAGE_POSTGRES_PG_SCHEMA_H_
#define WAYMARK_STORAGE_POSTGRES_PG_SCHEMA_H_

// The PostgreSQL schema and its migrations (issue 19). The tables are the SQLite schema's, in
// PostgreSQL's types (BIGINT identities, DOUBLE PRECISION, BYTEA), so both backends store the same
// records. The version is the one row of `waymark_schema`; each step runs in its own transaction
// under an advisory lock, so several servers starting at once against one database migrate it
// once. Steps are append-only; a released step is never edited.

#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/string_view.h"
#include "storage/postgres/pg.h"

namespace waymark::storage::pg {

// The PostgreSQL schema's steps, oldest first.
const std::vector<absl::string_view>& PostgresMigrations();

// The stored version (0 for a database Waymark has never used).
absl::StatusOr<int> ReadPostgresSchemaVersion(Connection& connection);

// Migrates the database to `steps.size()`. FAILED_PRECONDITION when it is newer (written by a
// newer build).
absl::Status MigratePostgres(Pool& pool, const std::vector<absl::string_view>& steps);

// Advisory-lock keys (pg_advisory_xact_lock takes a bigint). Each names what it serialises:
// schema migrations, and writes to one crossing database (key + database id).
inline constexpr int64_t kMigrationLockKey = 0x574d530000000000;      // "WMS"
inline constexpr int64_t kCrossingDatabaseLockBase = 0x574d430000000000;  // "WMC" + db id

}  // namespace waymark::storage::pg

#endif  // WAYMARK_STORAGE_POSTGRES_PG_SCHEMA_H_
