// OpenPostgres: one pool for a server's stores, the schema migrated before any store uses it.

#include <memory>
#include <utility>

#include "absl/strings/str_cat.h"
#include "storage/postgres/pg_schema.h"
#include "storage/postgres/pg_stores.h"
#include "storage/status_macros.h"

namespace waymark::storage {

absl::StatusOr<std::shared_ptr<pg::Pool>> OpenPostgres(const std::string& uri,
                                                       pg::Pool::Options options) {
  // A command line is visible to every user of the machine (ps) and ends up in logs and shell
  // histories; libpq reads the password from the environment or a 0600 file instead.
  if (pg::UriHasPassword(uri)) {
    return absl::InvalidArgumentError(
        absl::StrCat("the PostgreSQL URI ", pg::RedactUri(uri),
                     " carries a password: put it in PGPASSWORD or in a PGPASSFILE "
                     "(~/.pgpass) instead, and give the URI without it"));
  }
  ASSIGN_OR_RETURN(std::unique_ptr<pg::Pool> pool, pg::Pool::Open(uri, options));
  RETURN_IF_ERROR(pg::MigratePostgres(*pool, pg::PostgresMigrations()));
  return std::shared_ptr<pg::Pool>(std::move(pool));
}

}  // namespace waymark::storage
