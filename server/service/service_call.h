#ifndef WAYMARK_SERVER_SERVICE_SERVICE_CALL_H_
#define WAYMARK_SERVER_SERVICE_SERVICE_CALL_H_

// The shape every unary handler shares: authorize the caller for the RPC's action, run the
// registry call, copy its result into the response or translate its error.

#include <grpcpp/server_context.h>
#include <grpcpp/support/status.h>

#include <utility>

#include "absl/status/statusor.h"
#include "server/service/auth/authenticator.h"
#include "server/service/folder.h"
#include "server/service/runtime/grpc_status.h"

namespace waymark::service {

// Copies a registry result into the response, or returns its error.
template <typename T>
grpc::Status Reply(absl::StatusOr<T> result, T* response) {
  if (!result.ok()) return ToGrpcStatus(result.status());
  *response = std::move(*result);
  return grpc::Status::OK;
}

// Runs `call(caller)` (returning StatusOr<T>) for a caller allowed to do `action`.
template <typename T, typename Call>
grpc::Status ReplyAuthorized(Authenticator& auth, const grpc::ServerContext& context,
                             Action action, T* response, Call&& call) {
  absl::StatusOr<Caller> caller = auth.Authorize(context, action);
  if (!caller.ok()) return ToGrpcStatus(caller.status());
  return Reply(std::forward<Call>(call)(*caller), response);
}

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_SERVICE_CALL_H_
