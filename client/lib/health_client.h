#ifndef WAYMARK_CLIENT_LIB_HEALTH_CLIENT_H_
#define WAYMARK_CLIENT_LIB_HEALTH_CLIENT_H_

// The standard gRPC health check (grpc.health.v1.Health/Check) against a Waymark server: what
// container health checks and load balancers ask.

#include <grpcpp/channel.h>

#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "grpc/health/v1/health.pb.h"

namespace waymark::client {

// The serving status of `service` ("" = the server as a whole, or e.g. "waymark.v1.SlamService").
// UNAVAILABLE / DEADLINE_EXCEEDED when the server cannot be reached within `timeout`, NOT_FOUND
// for a service the server does not know.
absl::StatusOr<grpc::health::v1::HealthCheckResponse::ServingStatus> CheckHealth(
    const std::shared_ptr<grpc::ChannelInterface>& channel, const std::string& service,
    absl::Duration timeout);

}  // namespace waymark::client

#endif  // WAYMARK_CLIENT_LIB_HEALTH_CLIENT_H_
