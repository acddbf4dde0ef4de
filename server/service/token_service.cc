#include "server/service/token_service.h"

#include <cmath>
#include <string>

#include "absl/strings/str_cat.h"
#include "server/common/quote.h"
#include "server/service/service_call.h"
#include "storage/store_util.h"

namespace waymark::service {
namespace {

v1::TokenRole RoleToProto(storage::TokenRole role) {
  switch (role) {
    case storage::TokenRole::kRobot:
      return v1::ROBOT;
    case storage::TokenRole::kMapper:
      return v1::MAPPER;
    case storage::TokenRole::kAdmin:
      return v1::ADMIN;
    case storage::TokenRole::kViewer:
      return v1::VIEWER;
  }
  return v1::TOKEN_ROLE_UNSPECIFIED;
}

absl::StatusOr<storage::TokenRole> FromProto(v1::TokenRole role) {
  switch (role) {
    case v1::ROBOT:
      return storage::TokenRole::kRobot;
    case v1::MAPPER:
      return storage::TokenRole::kMapper;
    case v1::ADMIN:
      return storage::TokenRole::kAdmin;
    case v1::VIEWER:
      return storage::TokenRole::kViewer;
    default:
      return absl::InvalidArgumentError("role must be ROBOT, MAPPER, ADMIN or VIEWER");
  }
}

constexpr size_t kMaxTokenFieldBytes = 128;

absl::StatusOr<v1::CreatedToken> Create(storage::TokenStore& store,
                                        const v1::CreateTokenRequest& request) {
  absl::StatusOr<storage::TokenRole> role = FromProto(request.role());
  if (!role.ok()) return role.status();
  if (!std::isfinite(request.expires_in_seconds()) || request.expires_in_seconds() < 0) {
    return absl::InvalidArgumentError(absl::StrCat(
        "expires_in_seconds must be 0 (never) or positive, not ", request.expires_in_seconds()));
  }
  std::optional<double> expires_at;
  if (request.expires_in_seconds() > 0) expires_at = storage::NowSeconds() + request.expires_in_seconds();
  // Names and robot ids are listed, logged and compared on every call: bounded like a SLAM
  // session's robot id (an 8 MiB name made ListTokens answer 230 MB, refused by gRPC).
  for (const auto& [field, value] : {std::pair<const char*, const std::string*>{"name", &request.name()},
                                     {"robot_id", &request.robot_id()}}) {
    if (value->size() > kMaxTokenFieldBytes) {
      return absl::InvalidArgumentError(absl::StrCat(field, " is ", value->size(),
                                                     " bytes long; at most ", kMaxTokenFieldBytes));
    }
  }
  const std::string robot_id = request.robot_id().empty() ? request.name() : request.robot_id();
  absl::StatusOr<storage::CreatedToken> created =
      store.CreateToken(request.name(), robot_id, *role, expires_at);
  if (!created.ok()) return created.status();
  v1::CreatedToken response;
  *response.mutable_token() = ToProto(created->record);
  response.set_secret(created->secret);
  return response;
}

}  // namespace

v1::Token ToProto(const storage::TokenRecord& record) {
  v1::Token token;
  token.set_name(record.name);
  token.set_robot_id(record.robot_id);
  token.set_role(RoleToProto(record.role));
  token.set_created_at_unix(record.created_at);
  token.set_expires_at_unix(record.expires_at.value_or(0));
  token.set_revoked_at_unix(record.revoked_at.value_or(0));
  token.set_last_used_at_unix(record.last_used_at.value_or(0));
  return token;
}

grpc::Status TokenServiceImpl::CreateToken(grpc::ServerContext* context,
                                           const v1::CreateTokenRequest* request,
                                           v1::CreatedToken* response) {
  return ReplyAuthorized(*auth_, *context, Action::kManageTokens, response,
                         [&](const Caller&) { return Create(*store_, *request); });
}

grpc::Status TokenServiceImpl::ListTokens(grpc::ServerContext* context,
                                          const v1::ListTokensRequest*,
                                          v1::ListTokensResponse* response) {
  return ReplyAuthorized(*auth_, *context, Action::kManageTokens, response,
                         [&](const Caller&) -> absl::StatusOr<v1::ListTokensResponse> {
                           auto tokens = store_->ListTokens();
                           if (!tokens.ok()) return tokens.status();
                           v1::ListTokensResponse list;
                           for (const auto& token : *tokens) *list.add_tokens() = ToProto(token);
                           return list;
                         });
}

grpc::Status TokenServiceImpl::RevokeToken(grpc::ServerContext* context,
                                           const v1::RevokeTokenRequest* request,
                                           v1::Token* response) {
  return ReplyAuthorized(*auth_, *context, Action::kManageTokens, response,
                         [&](const Caller&) -> absl::StatusOr<v1::Token> {
                           if (absl::Status s = store_->RevokeToken(request->name()); !s.ok()) {
                             return s;
                           }
                           auth_->Forget();
                           auto tokens = store_->ListTokens();
                           if (!tokens.ok()) return tokens.status();
                           for (const auto& token : *tokens) {
                             if (token.name == request->name()) return ToProto(token);
                           }
                           return absl::NotFoundError(absl::StrCat(
                               "token ", QuoteClientText(request->name()), " vanished"));
                         });
}

}  // namespace waymark::service
