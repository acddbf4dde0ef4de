#ifndef WAYMARK_SERVER_SERVICE_OPERATIONS_CALL_INTERCEPTOR_H_
#define WAYMARK_SERVER_SERVICE_OPERATIONS_CALL_INTERCEPTOR_H_

// One server interceptor for every call: a request id, the call metrics and one log line.
//
//   - Request id: the client's "x-request-id" metadata if it is a plausible id (1-64 characters
//     of letters, digits, '.', '_', ':', '-'), else a fresh random 16-hex-digit id; sent back to
//     the client in the initial metadata "x-request-id", so a robot's log and the server's log
//     can be joined.
//   - Metrics (when given a Metrics): waymark_rpc_in_flight while the call runs; when it sends
//     its status, waymark_rpc_requests_total{method,code} and waymark_rpc_latency_seconds{method};
//     recognition outcomes of RecognizeCrossing and of each StreamRecognize answer.
//   - One log line when the call sends its status (spdlog's default logger), key=value:
//       rpc method=/waymark.v1.CrossingService/RecognizeCrossing code=OK ms=12.3
//           request_id=5f0c2a9e1b7d4c3a robot=robot-7 peer=ipv4:127.0.0.1:51234
//     streams add in=N out=M (messages received and sent); failed calls add error="..." (the
//     status message, escaped, at most 200 bytes) when the status has a message.
//     The robot is what the handler's auth check published through call_identity.h, "-" if none.
//     Level: warn for server-side failures (INTERNAL, UNKNOWN, DATA_LOSS), debug for successful
//     health checks (polled every few seconds by Docker/Kubernetes), info otherwise.
//
// Everything is recorded before the status is handed on, so when a client sees a call's status,
// its metrics and its log line are already there.
//
// Install with grpc::ServerBuilder::experimental().SetInterceptorCreators(...).

#include <grpcpp/support/server_interceptor.h>

#include <memory>

#include "server/service/operations/folder.h"
#include "server/service/operations/metrics.h"

namespace waymark::service {

inline constexpr char kRequestIdKey[] = "x-request-id";

// `metrics` may be null (logs and request ids only); otherwise it must outlive the server.
std::unique_ptr<grpc::experimental::ServerInterceptorFactoryInterface> MakeCallInterceptorFactory(
    Metrics* metrics);

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_OPERATIONS_CALL_INTERCEPTOR_H_
