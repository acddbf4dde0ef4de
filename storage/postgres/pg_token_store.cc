// TokenStore on PostgreSQL (issue 19), the port of sqlite_token_store.cc: this file holds the SQL;
// secrets, checks, the reading of rows and the messages are shared with the SQLite store
// (token_records.h). Each call is one statement, or (Authenticate) a read and an optional
// bookkeeping write that need not be atomic with it.

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"
#include "storage/postgres/pg.h"
#include "storage/postgres/pg_stores.h"
#include "storage/status_macros.h"
#include "storage/store_util.h"
#include "storage/stored_row.h"
#include "storage/token_records.h"
#include "storage/token_store.h"

namespace waymark::storage {
namespace {

using pg::Connection;
using pg::Params;
using pg::Result;
using pg::UniqueViolation;

class PostgresTokenStore final : public TokenStore {
 public:
  explicit PostgresTokenStore(std::shared_ptr<pg::Pool> pool) : pool_(std::move(pool)) {}

  absl::StatusOr<CreatedToken> CreateToken(const std::string& name, const std::string& robot_id,
                                           TokenRole role,
                                           std::optional<double> expires_at) override {
    ASSIGN_OR_RETURN(NewToken token, MakeNewToken(name, robot_id, role, expires_at));
    const TokenRecord& record = token.created.record;
    absl::StatusOr<int64_t> id =
        pool_->Run<int64_t>([&](Connection& connection) -> absl::StatusOr<int64_t> {
          // The only UNIQUE columns are name and the hash of 256 fresh random bits: a violation
          // is the name.
          ASSIGN_OR_RETURN(Result inserted,
                           connection.Execute("INSERT INTO tokens (name, robot_id, role, "
                                              "secret_hash, created_at, expires_at) "
                                              "VALUES ($1, $2, $3, $4, $5, $6) RETURNING id",
                                              Params()
                                                  .Text(record.name)
                                                  .Text(record.robot_id)
                                                  .Text(TokenRoleName(record.role))
                                                  .Bytes(token.secret_hash)
                                                  .Double(record.created_at)
                                                  .OptionalDouble(record.expires_at),
                                              UniqueViolation::kAlreadyExists));
          return inserted.Int64(0, 0);
        });
    if (absl::IsAlreadyExists(id.status())) return TokenAlreadyExists(name);
    RETURN_IF_ERROR(id.status());
    token.created.record.id = *id;
    return std::move(token.created);
  }

  absl::StatusOr<TokenRecord> Authenticate(absl::string_view secret, double now) override {
    ASSIGN_OR_RETURN(std::string hash, TokenLookupHash(secret));
    return pool_->Run<TokenRecord>([&](Connection& connection) -> absl::StatusOr<TokenRecord> {
      ASSIGN_OR_RETURN(Result rows,
                       connection.Execute(absl::StrCat(kSelectToken, "WHERE secret_hash = $1"),
                                          Params().Bytes(hash)));
      if (rows.rows() == 0) return UnknownToken();
      ASSIGN_OR_RETURN(TokenRecord token, ReadTokenRow(PgRow(rows, 0)));
      RETURN_IF_ERROR(CheckTokenLive(token, now));
      if (ShouldTouchLastUsed(token, now)) {
        // Bookkeeping only: a write that fails (a lost connection, a full disk) must not turn a
        // valid token away. The next call a minute later tries again.
        absl::StatusOr<Result> touched =
            connection.Execute("UPDATE tokens SET last_used_at = $1 WHERE id = $2",
                               Params().Double(now).Int64(token.id));
        if (touched.ok()) token.last_used_at = now;
      }
      return token;
    });
  }

  absl::StatusOr<std::vector<TokenRecord>> ListTokens() override {
    using Tokens = std::vector<TokenRecord>;
    return pool_->Run<Tokens>([&](Connection& connection) -> absl::StatusOr<Tokens> {
      ASSIGN_OR_RETURN(Result rows, connection.Execute(absl::StrCat(kSelectToken, "ORDER BY id")));
      Tokens tokens;
      tokens.reserve(static_cast<size_t>(rows.rows()));
      for (int row = 0; row < rows.rows(); ++row) {
        ASSIGN_OR_RETURN(TokenRecord token, ReadTokenRow(PgRow(rows, row)));
        tokens.push_back(std::move(token));
      }
      return tokens;
    });
  }

  absl::Status RevokeToken(const std::string& name) override {
    return pool_->Run([&](Connection& connection) -> absl::Status {
      // COALESCE keeps the first revocation time, so revoking twice is harmless.
      ASSIGN_OR_RETURN(Result updated,
                       connection.Execute("UPDATE tokens SET revoked_at = COALESCE(revoked_at, $1) "
                                          "WHERE name = $2",
                                          Params().Double(NowSeconds()).Text(name)));
      if (updated.affected() == 0) return TokenNotFound(name);
      return absl::OkStatus();
    });
  }

 private:
  std::shared_ptr<pg::Pool> pool_;
};

}  // namespace

std::unique_ptr<TokenStore> NewPostgresTokenStore(std::shared_ptr<pg::Pool> pool) {
  return std::make_unique<PostgresTokenStore>(std::move(pool));
}

}  // namespace waymark::storage
