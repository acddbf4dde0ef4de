#ifndef WAYMARK_STORAGE_POSTGRES_PG_ADMIN_H_
#define WAYMARK_STORAGE_POSTGRES_PG_ADMIN_H_

// Creating and dropping whole PostgreSQL databases on a server, and reading one value: what tests
// and benchmarks do to get an empty database of their own and look into it (the stores never
// create or drop databases).

#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"

namespace waymark::storage::pg {

// The URI of database `name` on the server `server_uri` names (its path replaced).
std::string DatabaseUri(const std::string& server_uri, const std::string& name);

// Drops database `name` if it exists (closing its connections) and creates it empty; returns its
// URI. `name` must be a plain identifier (letters, digits, '_'): INVALID_ARGUMENT otherwise.
absl::StatusOr<std::string> RecreateDatabase(const std::string& server_uri,
                                             const std::string& name);

// Drops database `name` if it exists, closing its connections.
absl::Status DropDatabase(const std::string& server_uri, const std::string& name);

// The first column of the first row of `sql` (a text value) on database `uri`: for benchmarks
// that look at what the servers stored. NOT_FOUND without a row; "" for NULL.
absl::StatusOr<std::string> QueryText(const std::string& uri, const std::string& sql);

}  // namespace waymark::storage::pg

#endif  // WAYMARK_STORAGE_POSTGRES_PG_ADMIN_H_
