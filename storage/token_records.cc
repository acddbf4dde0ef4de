#include "storage/token_records.h"

#include <openssl/rand.h>

#include <cmath>

#include "absl/strings/escaping.h"
#include "absl/strings/str_cat.h"
#include "storage/sha256.h"
#include "storage/status_macros.h"
#include "storage/store_util.h"

namespace waymark::storage {

const char* TokenRoleName(TokenRole role) {
  switch (role) {
    case TokenRole::kMapper:
      return "mapper";
    case TokenRole::kAdmin:
      return "admin";
    case TokenRole::kViewer:
      return "viewer";
    case TokenRole::kRobot:
      break;
  }
  return "robot";
}

absl::StatusOr<TokenRole> ParseTokenRole(absl::string_view name) {
  for (TokenRole role :
       {TokenRole::kRobot, TokenRole::kMapper, TokenRole::kAdmin, TokenRole::kViewer}) {
    if (name == TokenRoleName(role)) return role;
  }
  return absl::InvalidArgumentError(
      absl::StrCat("unknown token role \"", name, "\" (robot, mapper, admin or viewer)"));
}

namespace {

constexpr absl::string_view kSecretPrefix = "wm_";
constexpr int kSecretBytes = 32;
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

}  // namespace

absl::StatusOr<NewToken> MakeNewToken(const std::string& name, const std::string& robot_id,
                                      TokenRole role, std::optional<double> expires_at) {
  if (name.empty()) return absl::InvalidArgumentError("token name is empty");
  if (robot_id.empty()) return absl::InvalidArgumentError("token robot_id is empty");
  // SQLite would store NaN as NULL, i.e. "never expires": the opposite of what was meant.
  if (expires_at.has_value() && !std::isfinite(*expires_at)) {
    return absl::InvalidArgumentError("token expiry is not a finite number");
  }
  NewToken token;
  ASSIGN_OR_RETURN(token.created.secret, NewSecret());
  ASSIGN_OR_RETURN(token.secret_hash, HashSecret(token.created.secret));
  TokenRecord& record = token.created.record;
  record.name = name;
  record.robot_id = robot_id;
  record.role = role;
  record.created_at = NowSeconds();
  record.expires_at = expires_at;
  return token;
}

absl::StatusOr<std::string> TokenLookupHash(absl::string_view secret) {
  if (secret.empty()) return absl::UnauthenticatedError("no token given");
  return HashSecret(secret);
}

absl::Status UnknownToken() { return absl::UnauthenticatedError("unknown token"); }

absl::Status CheckTokenLive(const TokenRecord& token, double now) {
  if (token.revoked_at.has_value()) return absl::UnauthenticatedError("token is revoked");
  if (token.expires_at.has_value() && *token.expires_at <= now) {
    return absl::UnauthenticatedError("token has expired");
  }
  return absl::OkStatus();
}

bool ShouldTouchLastUsed(const TokenRecord& token, double now) {
  return !token.last_used_at.has_value() || now - *token.last_used_at >= kLastUsedResolutionSeconds;
}

absl::Status TokenAlreadyExists(absl::string_view name) {
  return absl::AlreadyExistsError(absl::StrCat("token ", Quoted(name), " already exists"));
}

absl::Status TokenNotFound(absl::string_view name) {
  return absl::NotFoundError(absl::StrCat("token ", Quoted(name), " not found"));
}

absl::StatusOr<TokenRecord> ReadTokenRow(const StoredRow& row) {
  TokenRecord token;
  token.id = row.Int64(0);
  token.name = row.Text(1);
  token.robot_id = row.Text(2);
  absl::StatusOr<TokenRole> role = ParseTokenRole(row.Bytes(3));
  if (!role.ok()) {
    return absl::DataLossError(
        absl::StrCat("token ", Quoted(token.name), ": ", role.status().message()));
  }
  token.role = *role;
  token.created_at = row.Double(4);
  token.expires_at = row.OptionalDouble(5);
  token.revoked_at = row.OptionalDouble(6);
  token.last_used_at = row.OptionalDouble(7);
  return token;
}

}  // namespace waymark::storage
