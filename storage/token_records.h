#ifndef WAYMARK_STORAGE_TOKEN_RECORDS_H_
#define WAYMARK_STORAGE_TOKEN_RECORDS_H_

// What the SQLite and PostgreSQL TokenStores share: making a new token (its secret and the hash
// that is stored instead), the columns they select and how a row becomes a record, the checks
// Authenticate makes and the error messages. Written once, so that a token behaves the same on
// both backends; each store keeps only its SQL.

#include <optional>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "storage/stored_row.h"
#include "storage/token_store.h"

namespace waymark::storage {

// A token about to be inserted: what CreateToken returns (the record's id still 0, the store
// fills it in) and the hash of its secret, the only form of it that is stored.
struct NewToken {
  CreatedToken created;
  std::string secret_hash;
};

// A token with a fresh random secret, created now. INVALID_ARGUMENT for an empty name or robot_id
// or a non-finite expiry; INTERNAL when no random secret can be had.
absl::StatusOr<NewToken> MakeNewToken(const std::string& name, const std::string& robot_id,
                                      TokenRole role, std::optional<double> expires_at);

// The hash a presented secret is looked up by. UNAUTHENTICATED for an empty secret.
absl::StatusOr<std::string> TokenLookupHash(absl::string_view secret);

// Authenticate's answers: no token has this secret; the token found is revoked or expired at
// `now` (OK when it is live).
absl::Status UnknownToken();
absl::Status CheckTokenLive(const TokenRecord& token, double now);

// Whether Authenticate should write last_used_at = now. Authenticate runs on every request;
// writing each time would turn every read into a write, so the column has a minute's resolution.
bool ShouldTouchLastUsed(const TokenRecord& token, double now);

absl::Status TokenAlreadyExists(absl::string_view name);
absl::Status TokenNotFound(absl::string_view name);

// "SELECT <the columns ReadTokenRow reads> FROM tokens ", for a WHERE / ORDER BY to follow. Never
// the hash: it stays inside the stores.
inline constexpr absl::string_view kSelectToken =
    "SELECT id, name, robot_id, role, created_at, expires_at, revoked_at, last_used_at "
    "FROM tokens ";
// DATA_LOSS for an unknown role.
absl::StatusOr<TokenRecord> ReadTokenRow(const StoredRow& row);

}  // namespace waymark::storage

#endif  // WAYMARK_STORAGE_TOKEN_RECORDS_H_
