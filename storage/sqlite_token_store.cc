// TokenStore on SQLite: one connection behind a mutex. Secrets, checks, row reading and messages
// are shared with the PostgreSQL store (token_records.h).

#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"
#include "storage/migrations.h"
#include "storage/sqlite.h"
#include "storage/status_macros.h"
#include "storage/store_util.h"
#include "storage/stored_row.h"
#include "storage/token_records.h"
#include "storage/token_store.h"

namespace waymark::storage {
namespace {

using sqlite::Connection;
using sqlite::Statement;
using sqlite::StepResult;
using sqlite::UniqueViolation;

class SqliteTokenStore final : public TokenStore {
 public:
  explicit SqliteTokenStore(Connection connection) : connection_(std::move(connection)) {}

  absl::StatusOr<CreatedToken> CreateToken(const std::string& name, const std::string& robot_id,
                                           TokenRole role,
                                           std::optional<double> expires_at) override {
    ASSIGN_OR_RETURN(NewToken token, MakeNewToken(name, robot_id, role, expires_at));
    const TokenRecord& record = token.created.record;
    std::lock_guard<std::mutex> lock(mutex_);
    ASSIGN_OR_RETURN(Statement stmt,
                     connection_.Prepare("INSERT INTO tokens (name, robot_id, role, secret_hash, "
                                         "created_at, expires_at) VALUES (?, ?, ?, ?, ?, ?)"));
    RETURN_IF_ERROR(stmt.BindText(1, record.name));
    RETURN_IF_ERROR(stmt.BindText(2, record.robot_id));
    RETURN_IF_ERROR(stmt.BindText(3, TokenRoleName(record.role)));
    RETURN_IF_ERROR(stmt.BindBlob(4, token.secret_hash.data(), token.secret_hash.size()));
    RETURN_IF_ERROR(stmt.BindDouble(5, record.created_at));
    RETURN_IF_ERROR(stmt.BindOptionalDouble(6, record.expires_at));
    // The only UNIQUE columns are name and the hash of 256 fresh random bits: a violation is the
    // name.
    absl::Status run = stmt.Run(UniqueViolation::kAlreadyExists);
    if (absl::IsAlreadyExists(run)) return TokenAlreadyExists(name);
    RETURN_IF_ERROR(run);
    token.created.record.id = connection_.LastInsertRowId();
    return std::move(token.created);
  }

  absl::StatusOr<TokenRecord> Authenticate(absl::string_view secret, double now) override {
    ASSIGN_OR_RETURN(std::string hash, TokenLookupHash(secret));
    std::lock_guard<std::mutex> lock(mutex_);
    ASSIGN_OR_RETURN(Statement stmt,
                     connection_.Prepare(absl::StrCat(kSelectToken, "WHERE secret_hash = ?")));
    RETURN_IF_ERROR(stmt.BindBlob(1, hash.data(), hash.size()));
    ASSIGN_OR_RETURN(StepResult step, stmt.Step());
    if (step != StepResult::kRow) return UnknownToken();
    ASSIGN_OR_RETURN(TokenRecord token, ReadTokenRow(SqliteRow(stmt)));
    RETURN_IF_ERROR(CheckTokenLive(token, now));
    if (ShouldTouchLastUsed(token, now)) {
      // Bookkeeping only: a write that fails (the database busy with a long enrollment, a full
      // disk) must not turn a valid token away. The next call a minute later tries again.
      if (TouchLastUsed(token.id, now).ok()) token.last_used_at = now;
    }
    return token;
  }

  absl::StatusOr<std::vector<TokenRecord>> ListTokens() override {
    std::lock_guard<std::mutex> lock(mutex_);
    ASSIGN_OR_RETURN(Statement stmt,
                     connection_.Prepare(absl::StrCat(kSelectToken, "ORDER BY id")));
    std::vector<TokenRecord> tokens;
    while (true) {
      ASSIGN_OR_RETURN(StepResult step, stmt.Step());
      if (step == StepResult::kDone) break;
      ASSIGN_OR_RETURN(TokenRecord token, ReadTokenRow(SqliteRow(stmt)));
      tokens.push_back(std::move(token));
    }
    return tokens;
  }

  absl::Status RevokeToken(const std::string& name) override {
    std::lock_guard<std::mutex> lock(mutex_);
    // COALESCE keeps the first revocation time, so revoking twice is harmless.
    ASSIGN_OR_RETURN(Statement stmt,
                     connection_.Prepare("UPDATE tokens SET revoked_at = COALESCE(revoked_at, ?) "
                                         "WHERE name = ?"));
    RETURN_IF_ERROR(stmt.BindDouble(1, NowSeconds()));
    RETURN_IF_ERROR(stmt.BindText(2, name));
    RETURN_IF_ERROR(stmt.Run());
    if (connection_.Changes() == 0) return TokenNotFound(name);
    return absl::OkStatus();
  }

 private:
  // Caller holds mutex_.
  absl::Status TouchLastUsed(int64_t id, double now) {
    ASSIGN_OR_RETURN(Statement update,
                     connection_.Prepare("UPDATE tokens SET last_used_at = ? WHERE id = ?"));
    RETURN_IF_ERROR(update.BindDouble(1, now));
    RETURN_IF_ERROR(update.BindInt64(2, id));
    return update.Run();
  }

  std::mutex mutex_;
  Connection connection_;
};

}  // namespace

absl::StatusOr<std::unique_ptr<TokenStore>> OpenSqliteTokenStore(const std::string& path) {
  ASSIGN_OR_RETURN(Connection connection, OpenMigratedDatabase(path));
  return std::unique_ptr<TokenStore>(new SqliteTokenStore(std::move(connection)));
}

}  // namespace waymark::storage
