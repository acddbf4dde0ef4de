#include "storage/postgres/pg_admin.h"

#include <memory>

#include "absl/strings/ascii.h"
#include "absl/strings/str_cat.h"
#include "storage/postgres/pg.h"
#include "storage/status_macros.h"

namespace waymark::storage::pg {
namespace {

// CREATE/DROP DATABASE take no parameters: the name is formatted in, so it must be harmless.
absl::Status CheckIdentifier(const std::string& name) {
  if (name.empty() || name.size() > 63) {
    return absl::InvalidArgumentError(
        absl::StrCat("database name \"", name, "\" is not 1-63 characters"));
  }
  for (char c : name) {
    if (!absl::ascii_isalnum(static_cast<unsigned char>(c)) && c != '_') {
      return absl::InvalidArgumentError(
          absl::StrCat("database name \"", name, "\" may hold only letters, digits and '_'"));
    }
  }
  return absl::OkStatus();
}

}  // namespace

std::string DatabaseUri(const std::string& server_uri, const std::string& name) {
  // postgresql://user@host:port/dbname?options: replace dbname, keep the options.
  const size_t authority = server_uri.find("://");
  const size_t start = authority == std::string::npos ? 0 : authority + 3;
  const size_t slash = server_uri.find('/', start);
  const size_t query = server_uri.find('?', start);
  const std::string head = server_uri.substr(0, slash == std::string::npos ? query : slash);
  const std::string tail = query == std::string::npos ? "" : server_uri.substr(query);
  return absl::StrCat(head, "/", name, tail);
}

absl::Status DropDatabase(const std::string& server_uri, const std::string& name) {
  RETURN_IF_ERROR(CheckIdentifier(name));
  ASSIGN_OR_RETURN(std::unique_ptr<Connection> admin, Connection::Open(server_uri));
  return admin->Script(absl::StrCat("DROP DATABASE IF EXISTS ", name, " WITH (FORCE)"));
}

absl::StatusOr<std::string> RecreateDatabase(const std::string& server_uri,
                                             const std::string& name) {
  RETURN_IF_ERROR(DropDatabase(server_uri, name));
  ASSIGN_OR_RETURN(std::unique_ptr<Connection> admin, Connection::Open(server_uri));
  RETURN_IF_ERROR(admin->Script(absl::StrCat("CREATE DATABASE ", name)));
  return DatabaseUri(server_uri, name);
}

absl::StatusOr<std::string> QueryText(const std::string& uri, const std::string& sql) {
  ASSIGN_OR_RETURN(std::unique_ptr<Connection> connection, Connection::Open(uri));
  ASSIGN_OR_RETURN(Result rows, connection->Execute(sql));
  if (rows.rows() == 0) return absl::NotFoundError(absl::StrCat("no row: ", sql));
  return rows.IsNull(0, 0) ? std::string() : rows.Text(0, 0);
}

}  // namespace waymark::storage::pg
