#include "client/lib/status_util.h"

#include <string>

namespace waymark::client {
namespace {

// Highest canonical code shared by both libraries (UNAUTHENTICATED = 16).
constexpr int kMaxCanonicalCode = 16;

bool IsCanonical(int code) { return code >= 0 && code <= kMaxCanonicalCode; }

// The mark is a payload, which absl::Status::ToString() prints: it is only set where the command
// line needs it (UNAVAILABLE), and says what it means when printed.
constexpr char kCallPayloadUrl[] = "waymark.call";
constexpr char kCallPayloadText[] = "from a gRPC call";

}  // namespace

absl::Status ToAbslStatus(const grpc::Status& status) {
  if (status.ok()) return absl::OkStatus();
  const int code = static_cast<int>(status.error_code());
  absl::Status converted(
      IsCanonical(code) ? static_cast<absl::StatusCode>(code) : absl::StatusCode::kUnknown,
      status.error_message());
  if (converted.code() == absl::StatusCode::kUnavailable) {
    converted.SetPayload(kCallPayloadUrl, absl::Cord(kCallPayloadText));
  }
  return converted;
}

bool IsUnavailableCall(const absl::Status& status) {
  return status.code() == absl::StatusCode::kUnavailable &&
         status.GetPayload(kCallPayloadUrl).has_value();
}

grpc::Status ToGrpcStatus(const absl::Status& status) {
  if (status.ok()) return grpc::Status::OK;
  const int code = static_cast<int>(status.code());
  return grpc::Status(
      IsCanonical(code) ? static_cast<grpc::StatusCode>(code) : grpc::StatusCode::UNKNOWN,
      std::string(status.message()));
}

}  // namespace waymark::client
