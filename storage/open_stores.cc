#include "storage/open_stores.h"

#include <utility>

#include "storage/postgres/pg.h"
#include "storage/postgres/pg_stores.h"
#include "storage/status_macros.h"

namespace waymark::storage {

bool IsPostgresDatabase(const std::string& db) { return pg::IsPostgresUri(db); }

std::string PrintableDatabase(const std::string& db) {
  return IsPostgresDatabase(db) ? pg::RedactUri(db) : db;
}

absl::StatusOr<Stores> OpenStores(const std::string& db) {
  Stores stores;
  if (IsPostgresDatabase(db)) {
    ASSIGN_OR_RETURN(std::shared_ptr<pg::Pool> pool, OpenPostgres(db));
    stores.crossing = NewPostgresCrossingStore(pool);
    stores.slam = NewPostgresSlamStore(pool);
    stores.token = NewPostgresTokenStore(pool);
    stores.map = NewPostgresMapStore(pool);
    return stores;
  }
  ASSIGN_OR_RETURN(stores.crossing, OpenSqliteCrossingStore(db));
  ASSIGN_OR_RETURN(stores.slam, OpenSqliteSlamStore(db));
  ASSIGN_OR_RETURN(stores.token, OpenSqliteTokenStore(db));
  ASSIGN_OR_RETURN(stores.map, OpenSqliteMapStore(db));
  return stores;
}

absl::StatusOr<std::unique_ptr<CrossingStore>> OpenCrossingStore(const std::string& db) {
  if (!IsPostgresDatabase(db)) return OpenSqliteCrossingStore(db);
  ASSIGN_OR_RETURN(std::shared_ptr<pg::Pool> pool, OpenPostgres(db));
  return NewPostgresCrossingStore(std::move(pool));
}

absl::StatusOr<std::unique_ptr<SlamStore>> OpenSlamStore(const std::string& db) {
  if (!IsPostgresDatabase(db)) return OpenSqliteSlamStore(db);
  ASSIGN_OR_RETURN(std::shared_ptr<pg::Pool> pool, OpenPostgres(db));
  return NewPostgresSlamStore(std::move(pool));
}

absl::StatusOr<std::unique_ptr<TokenStore>> OpenTokenStore(const std::string& db) {
  if (!IsPostgresDatabase(db)) return OpenSqliteTokenStore(db);
  ASSIGN_OR_RETURN(std::shared_ptr<pg::Pool> pool, OpenPostgres(db));
  return NewPostgresTokenStore(std::move(pool));
}

absl::StatusOr<std::unique_ptr<MapStore>> OpenMapStore(const std::string& db) {
  if (!IsPostgresDatabase(db)) return OpenSqliteMapStore(db);
  ASSIGN_OR_RETURN(std::shared_ptr<pg::Pool> pool, OpenPostgres(db));
  return NewPostgresMapStore(std::move(pool));
}

}  // namespace waymark::storage
