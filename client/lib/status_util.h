#ifndef WAYMARK_CLIENT_LIB_STATUS_UTIL_H_
#define WAYMARK_CLIENT_LIB_STATUS_UTIL_H_

#include <grpcpp/support/status.h>

#include "absl/status/status.h"

namespace waymark::client {

// gRPC and absl use the same numeric status codes, so the conversions keep the code and the message
// exactly; a code outside the canonical range (grpc's DO_NOT_USE) becomes UNKNOWN.
// An UNAVAILABLE status also carries a mark that it came from a call (IsUnavailableCall), so the
// command line can tell a server it cannot reach from a device that is unavailable.
absl::Status ToAbslStatus(const grpc::Status& status);
grpc::Status ToGrpcStatus(const absl::Status& status);

// True for an UNAVAILABLE status that ToAbslStatus made from a call's result: the server could not
// be reached, went away, or is shutting down.
bool IsUnavailableCall(const absl::Status& status);

}  // namespace waymark::client

#endif  // WAYMARK_CLIENT_LIB_STATUS_UTIL_H_
