#ifndef WAYMARK_SERVER_SERVICE_AUTH_CALL_IDENTITY_H_
#define WAYMARK_SERVER_SERVICE_AUTH_CALL_IDENTITY_H_

// Who made a call, handed from the auth check inside a handler to the call interceptor, which
// writes it into the call's log line. gRPC gives an interceptor no typed slot on the call for
// this, so the two meet in a small table keyed by the call's ServerContext.
//
// Lifetime of an entry (nothing may accumulate):
//   - the call interceptor (call_interceptor.h) takes the entry when the call sends its status,
//     and takes it again when the call is freed (its interceptor is destroyed with the call), so
//     a call that never sends a status leaves nothing behind either;
//   - it also drops any entry when a call starts, in case a context address is reused after an
//     entry was left by a server without the interceptor;
//   - without the interceptor installed nothing removes entries, so the table is capped
//     (kMaxCallIdentities); beyond that SetCallRobotId drops the id (the log says robot=-) and
//     warns once. waymark-server always installs the interceptor.
// Keys are only compared, never dereferenced, so a stale pointer is harmless.

#include <grpcpp/server_context.h>

#include <cstddef>
#include <string>

#include "server/service/auth/folder.h"

namespace waymark::service {

inline constexpr std::size_t kMaxCallIdentities = 1 << 16;

// Who made a call, set by the auth check inside the handler; read by the interceptor when the call
// ends.
void SetCallRobotId(const grpc::ServerContextBase* context, std::string robot_id);
std::string TakeCallRobotId(
    const grpc::ServerContextBase* context);  // "" if unset; erases the entry

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_AUTH_CALL_IDENTITY_H_
