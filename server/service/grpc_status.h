#ifndef WAYMARK_SERVER_SERVICE_GRPC_STATUS_H_
#define WAYMARK_SERVER_SERVICE_GRPC_STATUS_H_

#include <grpcpp/support/status.h>

#include "absl/status/status.h"

namespace waymark::service {

// absl and gRPC share the canonical code numbers, so the mapping is a cast.
inline grpc::Status ToGrpcStatus(const absl::Status& status) {
  if (status.ok()) return grpc::Status::OK;
  return grpc::Status(static_cast<grpc::StatusCode>(status.code()), std::string(status.message()));
}

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_GRPC_STATUS_H_
