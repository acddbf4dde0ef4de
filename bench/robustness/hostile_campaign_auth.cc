#include "bench/robustness/hostile_campaign_auth.h"

#include <filesystem>
#include <functional>
#include <set>
#include <thread>

#include "absl/strings/str_cat.h"
#include "client/lib/channel.h"
#include "client/lib/crossing_client.h"
#include "client/lib/health_client.h"
#include "client/lib/token_client.h"
#include "bench/robustness/hostile_campaign_shapes.h"

namespace waymark::bench::hostile {
namespace {

using grpc::StatusCode;
using Metadata = std::vector<std::pair<std::string, std::string>>;

// The RPCs only an admin may call (token.proto: TokenService; crossing: DeleteDatabase drops
// every robot's views, server/service/auth/access_policy.h).
bool AdminOnly(const RpcTarget& target) {
  return target.method->service()->name() == "TokenService" ||
         target.name == "CrossingService/DeleteDatabase";
}

// The health service answers anyone (load balancers and container checks have no token).
bool NeedsToken(const RpcTarget& target) {
  return target.method->service()->full_name() != "grpc.health.v1.Health";
}

// gRPC's default limit on a call's headers (GRPC_ARG_MAX_METADATA_SIZE), which the server keeps.
constexpr size_t kServerMetadataLimit = 8 << 10;

size_t MetadataBytes(const CallInput& input) {
  size_t bytes = 0;
  for (const auto& [key, value] : input.metadata) bytes += key.size() + value.size();
  return bytes;
}

struct AuthCase {
  std::string name;
  std::string expected;  // in words, for the report
  std::function<Metadata(Rng&)> metadata;
  std::function<bool(const RpcTarget&)> applies;
  // The codes that are right for this case (besides the health service's own answers).
  std::set<StatusCode> acceptable;
};

std::string RandomPrintable(Rng& rng, size_t n) {
  std::string s(n, ' ');
  for (char& c : s) c = static_cast<char>(std::uniform_int_distribution<int>(0x21, 0x7e)(rng));
  return s;
}

std::string RandomHex(Rng& rng, size_t n) {
  static const char kHex[] = "0123456789abcdef";
  std::string s(n, '0');
  for (char& c : s) c = kHex[rng() % 16];
  return s;
}

size_t OversizedBytes(Rng& rng) {
  static const size_t kSizes[] = {4 << 10, 9 << 10, 17 << 10, 64 << 10, 1 << 20};
  return kSizes[rng() % 5];
}

// Authorization values that are no valid token: random text, other schemes, near-misses of a
// real secret (one character off, cut, extended, two tokens). "bearer" in lower case and
// several spaces before the token are valid forms (RFC 7235), not garbage.
std::string GarbageAuthorization(Rng& rng, const std::string& secret) {
  std::string flipped = secret;
  flipped[3 + rng() % (flipped.size() - 3)] ^= 1;
  const std::vector<std::string> values = {
      "Bearer " + RandomPrintable(rng, 1 + rng() % 200),
      RandomPrintable(rng, 1 + rng() % 200),
      "Bearer ",
      "Bearer wm_" + RandomHex(rng, 64),
      "Bearer " + flipped,
      "Bearer " + secret + "x",
      "Bearer " + secret.substr(0, 40),
      "Basic dXNlcjpwYXNz",
      "Bearer wm_" + RandomHex(rng, 64) + " Bearer " + secret,
  };
  return values[rng() % values.size()];
}

// Creates a token on the database file with the server binary, as an operator would; its secret.
absl::StatusOr<std::string> CreateTokenWithBinary(const std::string& db, const std::string& name,
                                                  const std::string& role) {
  const testing::CommandResult created = testing::RunBinary(
      "waymark-server", absl::StrCat("--db ", db, " token create ", name, " --role ", role), false);
  if (created.code != 0) return absl::InternalError("token create failed: " + created.output);
  return created.output.substr(0, created.output.find('\n'));
}

std::shared_ptr<grpc::Channel> ChannelWith(const std::string& address, const std::string& secret) {
  client::ChannelOptions options;
  options.bearer_token = secret;
  return client::MakeChannel(address, options);
}

struct Secrets {
  std::string admin, robot, revoked, expired;
};

struct AuthServer {
  std::unique_ptr<WatchedServer> server;
  Secrets secrets;
};

// A server with auth on and tokens of every kind the cases need: made with the binary before
// the server starts, the revoked one used once while valid (so the server has it cached) and
// then revoked through the API, the expired one made to expire after a second.
absl::StatusOr<AuthServer> StartAuthServer(const std::string& db) {
  AuthServer started;
  Secrets& secrets = started.secrets;
  for (auto [name, role, secret] : {std::tuple{"auth-admin", "admin", &secrets.admin},
                                    std::tuple{"auth-robot", "robot", &secrets.robot},
                                    std::tuple{"auth-revoked", "robot", &secrets.revoked}}) {
    absl::StatusOr<std::string> made = CreateTokenWithBinary(db, name, role);
    if (!made.ok()) return made.status();
    *secret = *made;
  }
  absl::StatusOr<std::unique_ptr<WatchedServer>> server = WatchedServer::Start(db, true);
  if (!server.ok()) return server.status();
  started.server = *std::move(server);
  const std::string address = started.server->address();
  if (auto used = client::CrossingClient(ChannelWith(address, secrets.revoked)).ListDatabases();
      !used.ok()) {
    return used.status();
  }
  client::TokenClient admin(ChannelWith(address, secrets.admin));
  if (auto revoked = admin.RevokeToken("auth-revoked"); !revoked.ok()) return revoked.status();
  auto expiring = admin.CreateToken("auth-expired", "auth-robot", v1::ROBOT, absl::Seconds(1));
  if (!expiring.ok()) return expiring.status();
  secrets.expired = expiring->secret();
  std::this_thread::sleep_for(std::chrono::milliseconds(2500));
  return started;
}

std::vector<AuthCase> Cases(const Secrets& s) {
  const auto bearer = [](const std::string& secret) {
    return [secret](Rng&) { return Metadata{{"authorization", "Bearer " + secret}}; };
  };
  const auto all = [](const RpcTarget&) { return true; };
  const std::set<StatusCode> unauthenticated = {StatusCode::UNAUTHENTICATED};
  return {
      {"no token", "UNAUTHENTICATED", [](Rng&) { return Metadata{}; }, all, unauthenticated},
      {"garbage token", "UNAUTHENTICATED",
       [robot = s.robot](Rng& rng) {
         return Metadata{{"authorization", GarbageAuthorization(rng, robot)}};
       },
       all, unauthenticated},
      {"oversized token", "UNAUTHENTICATED or RESOURCE_EXHAUSTED",
       [](Rng& rng) {
         return Metadata{{"authorization", "Bearer " + RandomPrintable(rng, OversizedBytes(rng))}};
       },
       all, {StatusCode::UNAUTHENTICATED, StatusCode::RESOURCE_EXHAUSTED}},
      // With a valid robot token: big metadata beside it, one large header or a thousand small.
      {"oversized metadata, valid robot token",
       "RESOURCE_EXHAUSTED beyond the server's metadata limit; otherwise what the robot may do",
       [robot = s.robot](Rng& rng) {
         Metadata metadata = {{"authorization", "Bearer " + robot}};
         if (rng() % 2 == 0) {
           metadata.emplace_back("x-pad", RandomPrintable(rng, OversizedBytes(rng)));
         } else {
           for (int i = 0; i < 1000; ++i) metadata.emplace_back(absl::StrCat("x-pad-", i), RandomPrintable(rng, 64));
         }
         return metadata;
       },
       all,
       {StatusCode::RESOURCE_EXHAUSTED, StatusCode::OK, StatusCode::PERMISSION_DENIED,
        StatusCode::INVALID_ARGUMENT, StatusCode::NOT_FOUND, StatusCode::ALREADY_EXISTS,
        StatusCode::FAILED_PRECONDITION, StatusCode::CANCELLED}},
      {"revoked token", "UNAUTHENTICATED", bearer(s.revoked), all, unauthenticated},
      {"expired token", "UNAUTHENTICATED", bearer(s.expired), all, unauthenticated},
      {"robot token on admin RPCs", "PERMISSION_DENIED", bearer(s.robot), AdminOnly,
       {StatusCode::PERMISSION_DENIED}},
  };
}

std::vector<std::string> JudgeAuth(const AuthCase& c, const PlannedCall& call,
                                   const CallOutcome& outcome, const CallOutcome* previous) {
  std::vector<std::string> anomalies;
  const StatusCode code = outcome.code;
  if (AfterClosedConnection(outcome, previous)) {
    anomalies.push_back("unavailable_after_oversized_headers");
    return anomalies;
  }
  if (!NeedsToken(*call.target)) {
    // Health: answered without a token; a Watch is cancelled by the client after its answer.
    if (code != StatusCode::OK && code != StatusCode::CANCELLED &&
        c.acceptable.count(code) == 0) {
      anomalies.push_back("health_refused_" + CodeName(code));
    }
    return anomalies;
  }
  if (c.acceptable.count(code) > 0) return anomalies;
  if (code == StatusCode::UNAVAILABLE && MetadataBytes(call.input) > kServerMetadataLimit) {
    // gRPC's transport closes the connection for headers over its limit, racing the
    // RESOURCE_EXHAUSTED it answers otherwise: the robot sees a network error.
    anomalies.push_back("unavailable_for_own_oversized_headers");
  } else if (code == StatusCode::DEADLINE_EXCEEDED) {
    anomalies.push_back("possible_hang");
  } else if (code == StatusCode::OK) {
    anomalies.push_back("accepted_without_a_valid_token");
  } else {
    anomalies.push_back("unexpected_" + CodeName(code));
  }
  return anomalies;
}

Batch AuthBatch(const AuthCase& c, const std::vector<const RpcTarget*>& targets, int64_t requests) {
  Batch batch;
  batch.name = "auth: " + c.name;
  batch.budget = requests;
  batch.plan = [&c, targets](int thread, Rng& rng, int64_t index) {
    PlannedCall call;
    call.target = targets[static_cast<size_t>(index) % targets.size()];
    call.input = ValidCall(*call.target, thread, rng);
    call.input.shape = c.name;
    call.input.metadata = c.metadata(rng);
    return call;
  };
  batch.judge = [&c](const PlannedCall& call, const CallOutcome& outcome,
                     const CallOutcome* previous) { return JudgeAuth(c, call, outcome, previous); };
  return batch;
}

}  // namespace

nlohmann::json RunAuthPhase(const AuthOptions& options, SampleSaver* samples,
                            std::vector<std::pair<std::string, RpcStats>>* rows) {
  const std::string db = options.runner.out + "/work/auth.db";
  for (const char* suffix : {"", "-wal", "-shm"}) std::filesystem::remove(db + suffix);
  absl::StatusOr<AuthServer> started = StartAuthServer(db);
  if (!started.ok()) return {{"error", started.status().ToString()}};
  WatchedServer* server = started->server.get();
  const Secrets& secrets = started->secrets;
  absl::StatusOr<std::unique_ptr<Fixtures>> fixtures =
      Fixtures::Create(ChannelWith(server->address(), secrets.admin), options.runner.threads);
  if (!fixtures.ok()) return {{"error", "fixtures: " + fixtures.status().ToString()}};
  const std::vector<RpcTarget> targets = EnumerateTargets(**fixtures);
  Runner runner(server, samples, options.runner);
  nlohmann::json cases = nlohmann::json::array();
  const double rss_before = server->RssMb();
  for (const AuthCase& c : Cases(secrets)) {
    std::vector<const RpcTarget*> chosen;
    for (const RpcTarget& t : targets) {
      if (c.applies(t)) chosen.push_back(&t);
    }
    std::fprintf(stderr, "auth case: %s (%zu RPCs)\n", c.name.c_str(), chosen.size());
    const std::map<std::string, RpcStats> by_rpc = runner.Run(AuthBatch(c, chosen, options.requests_per_case));
    RpcStats total;
    nlohmann::json per_rpc = nlohmann::json::object();
    for (const auto& [name, stats] : by_rpc) {
      total.Merge(stats);
      per_rpc[name] = {{"calls", stats.calls()}, {"codes", stats.codes()}};
    }
    nlohmann::json row = total.ToJson();
    row["case"] = c.name;
    row["expected"] = c.expected;
    row["per_rpc"] = per_rpc;
    cases.push_back(row);
    rows->emplace_back("auth: " + c.name, total);
  }
  nlohmann::json out = {{"cases", cases},
                        {"rss_mb", {{"before", rss_before}, {"peak", server->PeakMb()}, {"after", server->RssMb()}}},
                        {"crashes", nlohmann::json::array()}};
  for (const CrashRecord& crash : runner.crashes()) out["crashes"].push_back(crash.ToJson());
  const bool alive = server->Alive();
  out["alive_after"] = alive;
  auto health = client::CheckHealth(client::MakeChannel(server->address()), "", absl::Seconds(10));
  out["health_after"] = health.ok() ? grpc::health::v1::HealthCheckResponse::ServingStatus_Name(*health)
                                    : health.status().ToString();
  out["log"] = SummarizeLog(server->Log());
  out["exit_code_on_sigterm"] = server->Terminate();
  out["database"] = CheckSqlite(db);
  return out;
}

}  // namespace waymark::bench::hostile
