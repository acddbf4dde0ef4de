#include "client/lib/token_client.h"

#include "client/lib/unary_call.h"

namespace waymark::client {

TokenClient::TokenClient(std::shared_ptr<grpc::ChannelInterface> channel,
                         TokenClientOptions options)
    : stub_(v1::TokenService::NewStub(std::move(channel))), options_(std::move(options)) {}

absl::StatusOr<v1::CreatedToken> TokenClient::CreateToken(const std::string& name,
                                                          const std::string& robot_id,
                                                          v1::TokenRole role,
                                                          absl::Duration expires_in) {
  v1::CreateTokenRequest request;
  request.set_name(name);
  request.set_robot_id(robot_id);
  request.set_role(role);
  if (expires_in > absl::ZeroDuration()) {
    request.set_expires_in_seconds(absl::ToDoubleSeconds(expires_in));
  }
  return CallUnary<v1::CreatedToken>(options_.timeout, options_.retry, Idempotency::kWrite,
                                     [&](auto* context, auto* response) {
                                       return stub_->CreateToken(context, request, response);
                                     });
}

absl::StatusOr<v1::ListTokensResponse> TokenClient::ListTokens() {
  v1::ListTokensRequest request;
  return CallUnary<v1::ListTokensResponse>(options_.timeout, options_.retry, Idempotency::kRead,
                                           [&](auto* context, auto* response) {
                                             return stub_->ListTokens(context, request, response);
                                           });
}

absl::StatusOr<v1::Token> TokenClient::RevokeToken(const std::string& name) {
  v1::RevokeTokenRequest request;
  request.set_name(name);
  return CallUnary<v1::Token>(options_.timeout, options_.retry, Idempotency::kWrite,
                              [&](auto* context, auto* response) {
                                return stub_->RevokeToken(context, request, response);
                              });
}

}  // namespace waymark::client
