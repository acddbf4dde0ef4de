#ifndef WAYMARK_SERVER_SERVICE_RUNTIME_GRPC_STATUS_H_
#define WAYMARK_SERVER_SERVICE_RUNTIME_GRPC_STATUS_H_

#include <grpcpp/support/status.h>

#include <string>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/string_view.h"
#include "server/service/runtime/folder.h"

namespace waymark::service {

// A status message travels in the response's headers, and clients refuse headers over 8 KiB
// (gRPC's default): a message quoting a client's 8 MiB name reached the client as
// RESOURCE_EXHAUSTED "received initial metadata size exceeds limit" and closed its connection,
// failing every call in flight on it (the issue 21 campaign). Messages are cut to this many bytes.
inline constexpr size_t kMaxStatusMessageBytes = 1024;

// `message` cut to kMaxStatusMessageBytes (at a UTF-8 character boundary), saying how much was cut.
inline std::string BoundedStatusMessage(absl::string_view message) {
  if (message.size() <= kMaxStatusMessageBytes) return std::string(message);
  size_t keep = kMaxStatusMessageBytes;
  while (keep > 0 && (static_cast<unsigned char>(message[keep]) & 0xC0) == 0x80) --keep;
  return absl::StrCat(message.substr(0, keep), "... (", message.size() - keep,
                      " more bytes cut)");
}

// absl and gRPC share the canonical code numbers, so the mapping is a cast.
inline grpc::Status ToGrpcStatus(const absl::Status& status) {
  if (status.ok()) return grpc::Status::OK;
  return grpc::Status(static_cast<grpc::StatusCode>(status.code()),
                      BoundedStatusMessage(status.message()));
}

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_RUNTIME_GRPC_STATUS_H_
