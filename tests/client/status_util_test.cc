#include "client/lib/status_util.h"

#include <gtest/gtest.h>

namespace waymark::client {
namespace {

TEST(StatusUtilTest, OkStaysOk) {
  EXPECT_TRUE(ToAbslStatus(grpc::Status::OK).ok());
  EXPECT_TRUE(ToGrpcStatus(absl::OkStatus()).ok());
}

TEST(StatusUtilTest, EveryCodeAndMessageSurviveBothDirections) {
  for (int code = 1; code <= 16; ++code) {
    const std::string message = "message for code " + std::to_string(code);
    const absl::Status absl_status =
        ToAbslStatus(grpc::Status(static_cast<grpc::StatusCode>(code), message));
    EXPECT_EQ(static_cast<int>(absl_status.code()), code);
    EXPECT_EQ(absl_status.message(), message);

    const grpc::Status grpc_status = ToGrpcStatus(absl_status);
    EXPECT_EQ(static_cast<int>(grpc_status.error_code()), code);
    EXPECT_EQ(grpc_status.error_message(), message);
  }
}

TEST(StatusUtilTest, NamedCodesMatch) {
  EXPECT_EQ(ToAbslStatus(grpc::Status(grpc::StatusCode::NOT_FOUND, "no db")),
            absl::NotFoundError("no db"));
  EXPECT_EQ(ToGrpcStatus(absl::ResourceExhaustedError("too big")).error_code(),
            grpc::StatusCode::RESOURCE_EXHAUSTED);
}

TEST(StatusUtilTest, OnlyUnavailableCallsAreMarkedAsSuch) {
  EXPECT_TRUE(IsUnavailableCall(ToAbslStatus(grpc::Status(grpc::StatusCode::UNAVAILABLE, "x"))));
  EXPECT_FALSE(IsUnavailableCall(absl::UnavailableError("serial port hung up")));
  EXPECT_FALSE(IsUnavailableCall(ToAbslStatus(grpc::Status(grpc::StatusCode::NOT_FOUND, "x"))));
}

TEST(StatusUtilTest, NonCanonicalCodeBecomesUnknown) {
  const absl::Status status = ToAbslStatus(grpc::Status(grpc::StatusCode::DO_NOT_USE, "odd"));
  EXPECT_EQ(status.code(), absl::StatusCode::kUnknown);
  EXPECT_EQ(status.message(), "odd");
}

}  // namespace
}  // namespace waymark::client
