#ifndef WAYMARK_CLIENT_LIB_STATUS_UTIL_H_
#define WAYMARK_CLIENT_LIB_STATUS_UTIL_H_

#include <grpcpp/support/status.h>

#include "absl/status/status.h"

namespace waymark::client {

// gRPC and absl use the same numeric status codes, so the conversions keep the code and the message
// exactly; a code outside the canonical range (grpc's DO_NOT_USE) becomes UNKNOWN.
absl::Status ToAbslStatus(const grpc::Status& status);
grpc::Status ToGrpcStatus(const absl::Status& status);

}  // namespace waymark::client

#endif  // WAYMARK_CLIENT_LIB_STATUS_UTIL_H_
