#ifndef WAYMARK_CLIENT_LIB_TOKEN_CLIENT_H_
#define WAYMARK_CLIENT_LIB_TOKEN_CLIENT_H_

// Typed, blocking access to waymark.v1.TokenService (admin tokens only): what `waymark token`
// uses, and what a fleet tool would.

#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "absl/time/time.h"
#include "client/lib/retry.h"
#include "waymark/v1/token.grpc.pb.h"

namespace waymark::client {

struct TokenClientOptions {
  absl::Duration timeout = absl::Seconds(30);  // per call, retries included
  RetryOptions retry;                          // ListTokens only: creating/revoking is sent once
};

class TokenClient {
 public:
  explicit TokenClient(std::shared_ptr<grpc::ChannelInterface> channel,
                       TokenClientOptions options = {});

  // `expires_in` <= 0 means never.
  absl::StatusOr<v1::CreatedToken> CreateToken(const std::string& name,
                                               const std::string& robot_id, v1::TokenRole role,
                                               absl::Duration expires_in);
  absl::StatusOr<v1::ListTokensResponse> ListTokens();
  absl::StatusOr<v1::Token> RevokeToken(const std::string& name);

 private:
  std::unique_ptr<v1::TokenService::Stub> stub_;
  TokenClientOptions options_;
};

}  // namespace waymark::client

#endif  // WAYMARK_CLIENT_LIB_TOKEN_CLIENT_H_
