#ifndef WAYMARK_STORAGE_TOKEN_STORE_H_
#define WAYMARK_STORAGE_TOKEN_STORE_H_

// Per-robot bearer tokens (issue 6): what the service's auth layer checks a request's token
// against. Only a SHA-256 of each secret is stored; the plaintext secret is returned once, by
// CreateToken, and cannot be recovered afterwards (a lost token is revoked and replaced). Deciding
// what a role may do is the service's job: this layer only stores and checks tokens.

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace waymark::storage {

// robot: recognize, its own SLAM sessions; mapper: also edit crossing databases; admin: all;
// viewer: only watch (read every robot's SLAM sessions and maps, the live view). Listed in the
// order they were added, not by rank (server/service/auth/access_policy.h ranks them).
enum class TokenRole { kRobot, kMapper, kAdmin, kViewer };

// "robot" / "mapper" / "admin" / "viewer", as stored and as typed on the command line.
const char* TokenRoleName(TokenRole role);
// The inverse of TokenRoleName; INVALID_ARGUMENT naming the valid roles otherwise.
absl::StatusOr<TokenRole> ParseTokenRole(absl::string_view name);

// A token as listed: everything but the secret and its hash.
struct TokenRecord {
  int64_t id = 0;
  std::string name;  // the operator's label, unique (e.g. the robot's name)
  std::string robot_id;
  TokenRole role = TokenRole::kRobot;
  double created_at = 0;               // unix seconds
  std::optional<double> expires_at;    // unset = never expires
  std::optional<double> revoked_at;    // unset = not revoked
  std::optional<double> last_used_at;  // unset = never used; updated at most once a minute
};

// What CreateToken returns: the record and the only copy of the secret there will ever be.
struct CreatedToken {
  TokenRecord record;
  std::string secret;  // "wm_" + 64 hex digits (32 random bytes)
};

// Every mutating call is one statement or transaction. Errors: INVALID_ARGUMENT (empty name or
// robot_id, non-finite expiry), ALREADY_EXISTS (duplicate name), NOT_FOUND (revoking an unknown
// name), UNAUTHENTICATED (Authenticate only), INTERNAL (database failure), UNAVAILABLE
// (PostgreSQL unreachable), DATA_LOSS (a stored row that cannot be read back).
class TokenStore {
 public:
  virtual ~TokenStore() = default;

  // Creates a token with a fresh random secret; `expires_at` in unix seconds.
  virtual absl::StatusOr<CreatedToken> CreateToken(const std::string& name,
                                                   const std::string& robot_id, TokenRole role,
                                                   std::optional<double> expires_at) = 0;
  // The live token whose secret this is, at time `now` (unix seconds; passed in so that callers
  // and tests control the clock). UNAUTHENTICATED when the secret is unknown, the token revoked or
  // expired; the message says which, and nothing about any other token.
  virtual absl::StatusOr<TokenRecord> Authenticate(absl::string_view secret, double now) = 0;
  // All tokens, revoked and expired ones included, in creation order.
  virtual absl::StatusOr<std::vector<TokenRecord>> ListTokens() = 0;
  // Marks the token revoked from now on. Revoking a revoked token is OK and keeps the first
  // revocation time. NOT_FOUND for an unknown name.
  virtual absl::Status RevokeToken(const std::string& name) = 0;
};

// Opens (creating if needed) a SQLite file and migrates it to the current schema, like
// OpenSqliteSlamStore; the file may be shared with the other stores.
absl::StatusOr<std::unique_ptr<TokenStore>> OpenSqliteTokenStore(const std::string& path);

}  // namespace waymark::storage

#endif  // WAYMARK_STORAGE_TOKEN_STORE_H_
