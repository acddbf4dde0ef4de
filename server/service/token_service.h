#ifndef WAYMARK_SERVER_SERVICE_TOKEN_SERVICE_H_
#define WAYMARK_SERVER_SERVICE_TOKEN_SERVICE_H_

// waymark.v1.TokenService: token management for admins (`waymark token create|list|revoke`).

#include <memory>

#include "server/service/auth/authenticator.h"
#include "server/service/folder.h"
#include "storage/token_store.h"
#include "waymark/v1/token.grpc.pb.h"

namespace waymark::service {

class TokenServiceImpl final : public v1::TokenService::Service {
 public:
  // `auth` checks that callers are admins and forgets cached tokens on revocation. Not owned.
  TokenServiceImpl(std::shared_ptr<storage::TokenStore> store, Authenticator* auth)
      : store_(std::move(store)), auth_(auth) {}

  grpc::Status CreateToken(grpc::ServerContext* context, const v1::CreateTokenRequest* request,
                           v1::CreatedToken* response) override;
  grpc::Status ListTokens(grpc::ServerContext* context, const v1::ListTokensRequest* request,
                          v1::ListTokensResponse* response) override;
  grpc::Status RevokeToken(grpc::ServerContext* context, const v1::RevokeTokenRequest* request,
                           v1::Token* response) override;

 private:
  std::shared_ptr<storage::TokenStore> store_;
  Authenticator* auth_;
};

// The API's view of a stored token (no secret).
v1::Token ToProto(const storage::TokenRecord& record);

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_TOKEN_SERVICE_H_
