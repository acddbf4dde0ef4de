#ifndef WAYMARK_SERVER_SERVICE_AUTH_AUTHENTICATOR_H_
#define WAYMARK_SERVER_SERVICE_AUTH_AUTHENTICATOR_H_

// The auth check every CrossingService, SlamService and TokenService handler runs first: reads the
// call's "authorization: Bearer <secret>" metadata, finds the token (storage::TokenStore), and
// checks the role against the action (access_policy.h). Done in the handlers rather than in a gRPC
// interceptor because a server interceptor cannot fail a call, and the handlers need the Caller
// anyway to keep robots to their own sessions.

#include <grpcpp/server_context.h>

#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <unordered_map>

#include "absl/status/statusor.h"
#include "server/service/auth/access_policy.h"
#include "server/service/auth/folder.h"
#include "storage/token_store.h"

namespace waymark::service {

struct AuthenticatorOptions {
  // A token found valid is trusted this long without asking the database again, so a busy robot
  // does not turn every call into a SQLite read. Revoking through this server's TokenService takes
  // effect at once; a revocation made elsewhere (the `waymark-server token revoke` command, another
  // server on the same file) within this time. Expiry is checked on every call.
  double cache_seconds = 5;
  // Entries beyond this are dropped (all of them: the cache refills from the database).
  size_t max_cached_tokens = 4096;
  // Unix seconds; replaceable so tests control expiry.
  std::function<double()> now;
};

class Authenticator {
 public:
  // Auth off (--insecure-dev): every call is allowed, as an admin with no robot id.
  static std::unique_ptr<Authenticator> AuthOff();
  // Tokens from `store` (shared with the TokenService, which revokes through Forget()).
  static std::unique_ptr<Authenticator> WithTokens(std::shared_ptr<storage::TokenStore> store,
                                                   AuthenticatorOptions options = {});

  bool auth_off() const { return store_ == nullptr; }

  // The caller of `context` if allowed to do `action`. UNAUTHENTICATED: no or malformed
  // authorization metadata, unknown/revoked/expired token. PERMISSION_DENIED: role too small.
  // Also publishes the caller's robot id for the call's log line (call_identity.h).
  absl::StatusOr<Caller> Authorize(const grpc::ServerContextBase& context, Action action);

  // The same check for a caller outside gRPC (the live view's page and WebSocket, which take the
  // token from a `token` query parameter or an "Authorization: Bearer" header): `secret` is the
  // token itself, "" when none was given (UNAUTHENTICATED).
  absl::StatusOr<Caller> AuthorizeSecret(const std::string& secret, Action action);

  // Drops cached tokens so a revocation is seen by the next call.
  void Forget();

  // A check of the token `context` was authorized with, to ask again later while its stream is
  // open (IdleStreamReaper): UNAUTHENTICATED once the token is revoked or expired (within the
  // cache's cache_seconds for a revocation made elsewhere; at once through this server's
  // TokenService or for expiry). It copies what it needs and may outlive the call, not this
  // Authenticator. Null with auth off.
  std::function<absl::Status()> Revalidation(const grpc::ServerContextBase& context);

 private:
  Authenticator(std::shared_ptr<storage::TokenStore> store, AuthenticatorOptions options);
  absl::StatusOr<Caller> Authenticate(const grpc::ServerContextBase& context);
  absl::StatusOr<storage::TokenRecord> Lookup(const std::string& secret, double now);

  struct CachedToken {
    storage::TokenRecord record;
    double checked_at = 0;
  };

  std::shared_ptr<storage::TokenStore> store_;  // nullptr: auth off
  AuthenticatorOptions options_;
  std::mutex mutex_;
  std::unordered_map<std::string, CachedToken> cache_;  // by secret
};

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_AUTH_AUTHENTICATOR_H_
