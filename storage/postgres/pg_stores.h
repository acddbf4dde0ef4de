#ifndef WAYMARK_STORAGE_POSTGRES_PG_STORES_H_
#define WAYMARK_STORAGE_POSTGRES_PG_STORES_H_

// The stores on PostgreSQL (issue 19): the same interfaces as the SQLite ones, the same
// transactions and the same error codes, so that several servers can share one database. The
// stores of one server share one connection pool.

#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "storage/crossing_store.h"
#include "storage/map_store.h"
#include "storage/postgres/pg.h"
#include "storage/slam_store.h"
#include "storage/token_store.h"

namespace waymark::storage {

// Connects to the libpq URI (`postgresql://user@host:port/dbname?...`; the password from
// PGPASSWORD / PGPASSFILE, or the URI) and migrates the database to the current schema.
// UNAVAILABLE when the server cannot be reached.
absl::StatusOr<std::shared_ptr<pg::Pool>> OpenPostgres(const std::string& uri,
                                                       pg::Pool::Options options = {});

std::unique_ptr<CrossingStore> NewPostgresCrossingStore(std::shared_ptr<pg::Pool> pool);
std::unique_ptr<SlamStore> NewPostgresSlamStore(std::shared_ptr<pg::Pool> pool);
std::unique_ptr<TokenStore> NewPostgresTokenStore(std::shared_ptr<pg::Pool> pool);
std::unique_ptr<MapStore> NewPostgresMapStore(std::shared_ptr<pg::Pool> pool);

}  // namespace waymark::storage

#endif  // WAYMARK_STORAGE_POSTGRES_PG_STORES_H_
