// TokenStore on SQLite: one connection behind a mutex; secrets hashed with OpenSSL's SHA-256.

#include <openssl/rand.h>

#include <chrono>
#include <cmath>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"
#include "storage/migrations.h"
#include "storage/sha256.h"
#include "storage/sqlite.h"
#include "storage/status_macros.h"
#include "storage/store_util.h"
#include "storage/token_store.h"

namespace waymark::storage {

const char* TokenRoleName(TokenRole role) {
  switch (role) {
    case TokenRole::kMapper:
      return "mapper";
    case TokenRole::kAdmin:
      return "admin";
    case TokenRole::kRobot:
      break;
  }
  return "robot";
}

absl::StatusOr<TokenRole> ParseTokenRole(absl::string_view name) {
  for (TokenRole role : {TokenRole::kRobot, TokenRole::kMapper, TokenRole::kAdmin}) {
    if (name == TokenRoleName(role)) return role;
  }
  return absl::InvalidArgumentError(
      absl::StrCat("unknown token role \"", name, "\" (robot, mapper or admin)"));
}

namespace {

using sqlite::Connection;
using sqlite::Statement;
using sqlite::StepResult;
using sqlite::UniqueViolation;

constexpr absl::string_view kSecretPrefix = "wm_";
constexpr int kSecretBytes = 32;
// Authenticate runs on every request; writing last_used_at each time would turn every read into a
// write. A minute's resolution is enough to tell a token in use from a forgotten one.
constexpr double kLastUsedResolutionSeconds = 60;

absl::StatusOr<std::string> NewSecret() {
  unsigned char bytes[kSecretBytes];
  if (RAND_bytes(bytes, kSecretBytes) != 1) {
    return absl::InternalError("OpenSSL RAND_bytes failed to generate a token secret");
  }
  return absl::StrCat(kSecretPrefix, absl::BytesToHexString(absl::string_view(
                                         reinterpret_cast<const char*>(bytes), kSecretBytes)));
}

// The secrets are 256 random bits, so a plain (unsalted, fast) hash is enough: there is nothing to
// guess, and it lets Authenticate find the row by an index lookup on the hash.
absl::StatusOr<std::string> HashSecret(absl::string_view secret) { return Sha256(secret); }

// Columns read by ReadTokenRow, in order. Never the hash: it stays inside this file.
constexpr absl::string_view kSelectToken =
    "SELECT id, name, robot_id, role, created_at, expires_at, revoked_at, last_used_at "
    "FROM tokens ";

absl::StatusOr<TokenRecord> ReadTokenRow(const Statement& row) {
  TokenRecord token;
  token.id = row.ColumnInt64(0);
  token.name = row.ColumnText(1);
  token.robot_id = row.ColumnText(2);
  absl::StatusOr<TokenRole> role = ParseTokenRole(row.ColumnText(3));
  if (!role.ok()) {
    return absl::DataLossError(
        absl::StrCat("token ", Quoted(token.name), ": ", role.status().message()));
  }
  token.role = *role;
  token.created_at = row.ColumnDouble(4);
  token.expires_at = row.ColumnOptionalDouble(5);
  token.revoked_at = row.ColumnOptionalDouble(6);
  token.last_used_at = row.ColumnOptionalDouble(7);
  return token;
}

class SqliteTokenStore final : public TokenStore {
 public:
  explicit SqliteTokenStore(Connection connection) : connection_(std::move(connection)) {}

  absl::StatusOr<CreatedToken> CreateToken(const std::string& name, const std::string& robot_id,
                                           TokenRole role,
                                           std::optional<double> expires_at) override {
    if (name.empty()) return absl::InvalidArgumentError("token name is empty");
    if (robot_id.empty()) return absl::InvalidArgumentError("token robot_id is empty");
    // SQLite would store NaN as NULL, i.e. "never expires": the opposite of what was meant.
    if (expires_at.has_value() && !std::isfinite(*expires_at)) {
      return absl::InvalidArgumentError("token expiry is not a finite number");
    }
    CreatedToken created;
    ASSIGN_OR_RETURN(created.secret, NewSecret());
    ASSIGN_OR_RETURN(std::string hash, HashSecret(created.secret));
    created.record.name = name;
    created.record.robot_id = robot_id;
    created.record.role = role;
    created.record.created_at = NowSeconds();
    created.record.expires_at = expires_at;

    std::lock_guard<std::mutex> lock(mutex_);
    ASSIGN_OR_RETURN(Statement stmt,
                     connection_.Prepare("INSERT INTO tokens (name, robot_id, role, secret_hash, "
                                         "created_at, expires_at) VALUES (?, ?, ?, ?, ?, ?)"));
    RETURN_IF_ERROR(stmt.BindText(1, name));
    RETURN_IF_ERROR(stmt.BindText(2, robot_id));
    RETURN_IF_ERROR(stmt.BindText(3, TokenRoleName(role)));
    RETURN_IF_ERROR(stmt.BindBlob(4, hash.data(), hash.size()));
    RETURN_IF_ERROR(stmt.BindDouble(5, created.record.created_at));
    RETURN_IF_ERROR(stmt.BindOptionalDouble(6, expires_at));
    // The only UNIQUE columns are name and the hash of 256 fresh random bits: a violation is the
    // name.
    absl::Status run = stmt.Run(UniqueViolation::kAlreadyExists);
    if (absl::IsAlreadyExists(run)) {
      return absl::AlreadyExistsError(absl::StrCat("token ", Quoted(name), " already exists"));
    }
    RETURN_IF_ERROR(run);
    created.record.id = connection_.LastInsertRowId();
    return created;
  }

  absl::StatusOr<TokenRecord> Authenticate(absl::string_view secret, double now) override {
    if (secret.empty()) return absl::UnauthenticatedError("no token given");
    ASSIGN_OR_RETURN(std::string hash, HashSecret(secret));
    std::lock_guard<std::mutex> lock(mutex_);
    ASSIGN_OR_RETURN(Statement stmt,
                     connection_.Prepare(absl::StrCat(kSelectToken, "WHERE secret_hash = ?")));
    RETURN_IF_ERROR(stmt.BindBlob(1, hash.data(), hash.size()));
    ASSIGN_OR_RETURN(StepResult step, stmt.Step());
    if (step != StepResult::kRow) return absl::UnauthenticatedError("unknown token");
    ASSIGN_OR_RETURN(TokenRecord token, ReadTokenRow(stmt));
    if (token.revoked_at.has_value()) return absl::UnauthenticatedError("token is revoked");
    if (token.expires_at.has_value() && *token.expires_at <= now) {
      return absl::UnauthenticatedError("token has expired");
    }
    if (!token.last_used_at.has_value() ||
        now - *token.last_used_at >= kLastUsedResolutionSeconds) {
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
      ASSIGN_OR_RETURN(TokenRecord token, ReadTokenRow(stmt));
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
    if (connection_.Changes() == 0) {
      return absl::NotFoundError(absl::StrCat("token ", Quoted(name), " not found"));
    }
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
