// Fuzz target token_requests: the TokenService's requests (CreateToken, ListTokens, RevokeToken)
// served by the real TokenServiceImpl over an in-memory SQLite token store, and the other thing
// every call carries: its "authorization" metadata, checked by the Authenticator against the same
// store (bearer parsing, the secret's lookup and cache, the role against the action).
//
// RPC 3 is the metadata: its "message" is not a protobuf but one byte picking the action, then
// the metadata value; "@robot" and "@admin" in it stand for the secrets of the store's two tokens
// (made at random per process, so a seed cannot hold them). After each input that changed the
// tokens the store is made again, so every input meets the same two live tokens.

#include <grpcpp/test/server_context_test_spouse.h>

#include <memory>
#include <string>
#include <vector>

#include "absl/strings/str_replace.h"
#include "server/service/auth/authenticator.h"
#include "server/service/token_service.h"
#include "storage/token_store.h"
#include "tests/fuzz/fuzz_targets.h"
#include "tests/fuzz/service_calls.h"

namespace waymark::fuzz {
namespace {

using service::TokenServiceImpl;

constexpr int kActions = 6;  // service::Action's values

class TokenFixture {
 public:
  TokenFixture() {
    QuietLogs();
    Build();
  }

  void Run(const RequestInput& input) {
    switch (input.rpc % 4) {
      case 0:
        UnaryRpc(service_.get(), &TokenServiceImpl::CreateToken)(input);
        break;
      case 1:
        UnaryRpc(service_.get(), &TokenServiceImpl::ListTokens)(input);
        break;
      case 2:
        UnaryRpc(service_.get(), &TokenServiceImpl::RevokeToken)(input);
        break;
      default:
        Authorize(input);
        break;
    }
    if (Tokens() != baseline_) Build();
  }

 private:
  void Build() {
    auto store = storage::OpenSqliteTokenStore(":memory:");
    Require(store.status(), "opening an in-memory token store");
    store_ = *std::move(store);
    const auto create = [&](const char* name, storage::TokenRole role) {
      auto created = store_->CreateToken(name, name, role, std::nullopt);
      Require(created.status(), "creating a fixture token");
      return created->secret;
    };
    robot_secret_ = create("robot-1", storage::TokenRole::kRobot);
    admin_secret_ = create("admin", storage::TokenRole::kAdmin);
    tokens_ = service::Authenticator::WithTokens(store_);
    service_ = std::make_unique<TokenServiceImpl>(store_, admin_.get());
    baseline_ = Tokens();
  }

  // The tokens' names and whether each is revoked: what an input may change.
  std::string Tokens() {
    auto tokens = store_->ListTokens();
    Require(tokens.status(), "listing tokens");
    std::string state;
    for (const storage::TokenRecord& t : *tokens) {
      state += t.name + (t.revoked_at.has_value() ? "\x01" : "\x02");
    }
    return state;
  }

  void Authorize(const RequestInput& input) {
    if (input.size == 0) return;
    const auto action = static_cast<service::Action>(input.message[0] % kActions);
    const std::string value = absl::StrReplaceAll(
        std::string(reinterpret_cast<const char*>(input.message + 1), input.size - 1),
        {{"@robot", robot_secret_}, {"@admin", admin_secret_}});
    grpc::ServerContext context;
    // The spouse holds the metadata the context points into: it must outlive the checks.
    grpc::testing::ServerContextTestSpouse spouse(&context);
    spouse.AddClientMetadata("authorization", value);
    (void)tokens_->Authorize(context, action);
    if (auto revalidate = tokens_->Revalidation(context)) (void)revalidate();
  }

  std::shared_ptr<storage::TokenStore> store_;
  std::string robot_secret_, admin_secret_;
  std::unique_ptr<service::Authenticator> tokens_;  // checks metadata against store_
  std::unique_ptr<service::Authenticator> admin_ = service::Authenticator::AuthOff();
  std::unique_ptr<TokenServiceImpl> service_;
  std::string baseline_;
};

void TokenRequests(const uint8_t* data, size_t size) {
  static TokenFixture* fixture = new TokenFixture;  // never destroyed, like the other fixtures
  if (std::optional<RequestInput> input = SplitRequestInput(data, size)) fixture->Run(*input);
}

std::string AuthSeed(service::Action action, const std::string& value) {
  return std::string(1, '\x03') + std::string(1, static_cast<char>(action)) + value;
}

std::vector<std::string> TokenSeeds() {
  v1::CreateTokenRequest create;
  create.set_name("robot-2");
  create.set_robot_id("pioneer-7");
  create.set_role(v1::MAPPER);
  create.set_expires_in_seconds(3600);
  v1::RevokeTokenRequest revoke;
  revoke.set_name("robot-1");
  return {RequestSeed(0, create),
          RequestSeed(1, v1::ListTokensRequest()),
          RequestSeed(2, revoke),
          AuthSeed(service::Action::kSlam, "Bearer @robot"),
          AuthSeed(service::Action::kDeleteDatabase, "bearer   @robot  "),
          AuthSeed(service::Action::kManageTokens, "Bearer @admin"),
          AuthSeed(service::Action::kRecognize, "Bearer wm_0123456789abcdef")};
}

}  // namespace

FuzzTarget TokenRequestsTarget() { return {"token_requests", TokenRequests, TokenSeeds}; }

}  // namespace waymark::fuzz
