#include "server/service/auth/authenticator.h"

#include <utility>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"
#include "server/service/auth/call_identity.h"
#include "storage/store_util.h"

namespace waymark::service {
namespace {

constexpr absl::string_view kBearer = "bearer ";

// The secret of "authorization: Bearer <secret>", or UNAUTHENTICATED saying what is wrong.
absl::StatusOr<std::string> BearerSecret(const grpc::ServerContextBase& context) {
  const auto& metadata = context.client_metadata();
  const auto found = metadata.find("authorization");
  if (found == metadata.end()) {
    return absl::UnauthenticatedError(
        "no token: send \"authorization: Bearer <token>\" metadata (waymark --token or "
        "WAYMARK_TOKEN; an admin creates tokens with `waymark token create`)");
  }
  const absl::string_view value(found->second.data(), found->second.size());
  if (!absl::StartsWithIgnoreCase(value, kBearer)) {
    return absl::UnauthenticatedError(
        "malformed authorization metadata: expected \"Bearer <token>\"");
  }
  const absl::string_view secret = absl::StripAsciiWhitespace(value.substr(kBearer.size()));
  if (secret.empty()) return absl::UnauthenticatedError("empty bearer token");
  return std::string(secret);
}

}  // namespace

std::unique_ptr<Authenticator> Authenticator::AuthOff() {
  return std::unique_ptr<Authenticator>(new Authenticator(nullptr, {}));
}

std::unique_ptr<Authenticator> Authenticator::WithTokens(
    std::shared_ptr<storage::TokenStore> store, AuthenticatorOptions options) {
  return std::unique_ptr<Authenticator>(new Authenticator(std::move(store), std::move(options)));
}

Authenticator::Authenticator(std::shared_ptr<storage::TokenStore> store,
                             AuthenticatorOptions options)
    : store_(std::move(store)), options_(std::move(options)) {
  if (!options_.now) options_.now = storage::NowSeconds;
}

absl::StatusOr<Caller> Authenticator::Authorize(const grpc::ServerContextBase& context,
                                                Action action) {
  absl::StatusOr<Caller> caller = Authenticate(context);
  if (!caller.ok()) return caller.status();
  if (!caller->auth_off) SetCallRobotId(&context, caller->robot_id);
  if (absl::Status allowed = CheckAction(*caller, action); !allowed.ok()) return allowed;
  return caller;
}

absl::StatusOr<Caller> Authenticator::AuthorizeSecret(const std::string& secret, Action action) {
  Caller caller;
  if (auth_off()) {
    caller.role = storage::TokenRole::kAdmin;
    caller.auth_off = true;
    return caller;
  }
  if (secret.empty()) {
    return absl::UnauthenticatedError(
        "no token: give a viewer token as ?token=SECRET or \"Authorization: Bearer SECRET\" (an "
        "admin creates one with `waymark token create NAME --role viewer`)");
  }
  absl::StatusOr<storage::TokenRecord> token = Lookup(secret, options_.now());
  if (!token.ok()) return token.status();
  caller.token_name = token->name;
  caller.robot_id = token->robot_id;
  caller.role = token->role;
  if (absl::Status allowed = CheckAction(caller, action); !allowed.ok()) return allowed;
  return caller;
}

absl::StatusOr<Caller> Authenticator::Authenticate(const grpc::ServerContextBase& context) {
  Caller caller;
  if (auth_off()) {
    caller.role = storage::TokenRole::kAdmin;
    caller.auth_off = true;
    return caller;
  }
  absl::StatusOr<std::string> secret = BearerSecret(context);
  if (!secret.ok()) return secret.status();
  absl::StatusOr<storage::TokenRecord> token = Lookup(*secret, options_.now());
  if (!token.ok()) return token.status();
  caller.token_name = token->name;
  caller.robot_id = token->robot_id;
  caller.role = token->role;
  return caller;
}

absl::StatusOr<storage::TokenRecord> Authenticator::Lookup(const std::string& secret, double now) {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    const auto cached = cache_.find(secret);
    if (cached != cache_.end() && now - cached->second.checked_at < options_.cache_seconds) {
      const storage::TokenRecord& record = cached->second.record;
      if (!record.expires_at.has_value() || now < *record.expires_at) return record;
      cache_.erase(cached);  // expired since it was cached: let the store say so
    }
  }
  absl::StatusOr<storage::TokenRecord> record = store_->Authenticate(secret, now);
  if (!record.ok()) return record.status();
  std::lock_guard<std::mutex> lock(mutex_);
  if (cache_.size() >= options_.max_cached_tokens) cache_.clear();
  cache_[secret] = CachedToken{*record, now};
  return record;
}

std::function<absl::Status()> Authenticator::Revalidation(const grpc::ServerContextBase& context) {
  if (auth_off()) return nullptr;
  absl::StatusOr<std::string> secret = BearerSecret(context);
  if (!secret.ok()) return nullptr;  // not authorized in the first place
  return [this, secret = *std::move(secret)] { return Lookup(secret, options_.now()).status(); };
}

void Authenticator::Forget() {
  std::lock_guard<std::mutex> lock(mutex_);
  cache_.clear();
}

}  // namespace waymark::service
