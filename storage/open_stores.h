#ifndef WAYMARK_STORAGE_OPEN_STORES_H_
#define WAYMARK_STORAGE_OPEN_STORES_H_

// Opens the stores a `--db` value names: a PostgreSQL database for a libpq URI
// ("postgresql://..." or "postgres://..."), a SQLite file otherwise (a path, or ":memory:").

#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "storage/crossing_store.h"
#include "storage/map_store.h"
#include "storage/slam_store.h"
#include "storage/token_store.h"

namespace waymark::storage {

// True when `db` is a PostgreSQL URI.
bool IsPostgresDatabase(const std::string& db);

// `db` as it may be printed: a URI without its password.
std::string PrintableDatabase(const std::string& db);

// Every store of one server; on PostgreSQL they share one connection pool.
struct Stores {
  std::unique_ptr<CrossingStore> crossing;
  std::unique_ptr<SlamStore> slam;
  std::unique_ptr<TokenStore> token;
  std::unique_ptr<MapStore> map;  // maps shared by robots (issue 38)
};
absl::StatusOr<Stores> OpenStores(const std::string& db);

// One store alone (tests, `waymark-server token ...`).
absl::StatusOr<std::unique_ptr<CrossingStore>> OpenCrossingStore(const std::string& db);
absl::StatusOr<std::unique_ptr<SlamStore>> OpenSlamStore(const std::string& db);
absl::StatusOr<std::unique_ptr<TokenStore>> OpenTokenStore(const std::string& db);
absl::StatusOr<std::unique_ptr<MapStore>> OpenMapStore(const std::string& db);

}  // namespace waymark::storage

#endif  // WAYMARK_STORAGE_OPEN_STORES_H_
