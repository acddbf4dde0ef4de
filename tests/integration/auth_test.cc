// Authentication and authorization against the real server binary (auth on, as deployed): every
// RPC x every role, missing/wrong/malformed/expired/revoked tokens, two robots' sessions kept
// apart, the per-robot stream cap, token management over the API and on the database file.
#include <gmock/gmock.h>
#include <grpcpp/grpcpp.h>
#include <gtest/gtest.h>

#include <chrono>
#include <functional>
#include <limits>
#include <map>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "client/lib/channel.h"
#include "client/lib/health_client.h"
#include "storage/store_util.h"
#include "storage/token_store.h"
#include "tests/service/slam_test_world.h"
#include "tests/support/server_process.h"
#include "waymark/v1/crossing.grpc.pb.h"
#include "waymark/v1/slam.grpc.pb.h"
#include "waymark/v1/token.grpc.pb.h"

namespace waymark {
namespace {

using storage::TokenRole;
using ::testing::HasSubstr;

std::unique_ptr<grpc::ClientContext> Ctx() {
  auto ctx = std::make_unique<grpc::ClientContext>();
  ctx->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(30));
  return ctx;
}

// One call of one RPC with a harmless request; returns the status the server answered.
using Rpc = std::function<grpc::Status(const std::shared_ptr<grpc::Channel>&)>;

template <typename Request, typename Response, typename Stub, typename Method>
Rpc Unary(Method method) {
  return [method](const std::shared_ptr<grpc::Channel>& channel) {
    Stub stub(channel);
    Request request;
    Response response;
    return (stub.*method)(Ctx().get(), request, &response);
  };
}

// Minimum role per RPC (the table in server/service/auth/access_policy.h, written out again so that a
// change there has to be made on purpose here).
struct RpcCase {
  std::string name;
  TokenRole needs;
  Rpc call;
};

std::vector<RpcCase> AllRpcs() {
  using CS = v1::CrossingService::Stub;
  using SS = v1::SlamService::Stub;
  using TS = v1::TokenService::Stub;
  std::vector<RpcCase> rpcs = {
      {"CreateDatabase", TokenRole::kMapper,
       Unary<v1::CreateDatabaseRequest, v1::CrossingDatabase, CS>(&CS::CreateDatabase)},
      {"ListDatabases", TokenRole::kRobot,
       Unary<v1::ListDatabasesRequest, v1::ListDatabasesResponse, CS>(&CS::ListDatabases)},
      {"DeleteDatabase", TokenRole::kAdmin,
       Unary<v1::DeleteDatabaseRequest, v1::DeleteDatabaseResponse, CS>(&CS::DeleteDatabase)},
      {"GetDatabaseStats", TokenRole::kRobot,
       Unary<v1::GetDatabaseStatsRequest, v1::DatabaseStats, CS>(&CS::GetDatabaseStats)},
      {"AddCrossing", TokenRole::kMapper,
       Unary<v1::AddCrossingRequest, v1::Crossing, CS>(&CS::AddCrossing)},
      {"ListCrossings", TokenRole::kRobot,
       Unary<v1::ListCrossingsRequest, v1::ListCrossingsResponse, CS>(&CS::ListCrossings)},
      {"DeleteCrossing", TokenRole::kMapper,
       Unary<v1::DeleteCrossingRequest, v1::DeleteCrossingResponse, CS>(&CS::DeleteCrossing)},
      {"EnrollView", TokenRole::kMapper,
       Unary<v1::EnrollViewRequest, v1::EnrollViewResponse, CS>(&CS::EnrollView)},
      {"RebuildClusters", TokenRole::kMapper,
       Unary<v1::RebuildClustersRequest, v1::RebuildClustersResponse, CS>(&CS::RebuildClusters)},
      {"RecognizeCrossing", TokenRole::kRobot,
       Unary<v1::RecognizeRequest, v1::RecognizeResponse, CS>(&CS::RecognizeCrossing)},
      {"BulkEnroll", TokenRole::kMapper,
       [](const std::shared_ptr<grpc::Channel>& channel) {
         CS stub(channel);
         auto ctx = Ctx();
         v1::BulkEnrollResponse response;
         auto writer = stub.BulkEnroll(ctx.get(), &response);
         writer->WritesDone();
         return writer->Finish();
       }},
      {"StreamEnroll", TokenRole::kMapper,
       [](const std::shared_ptr<grpc::Channel>& channel) {
         CS stub(channel);
         auto ctx = Ctx();
         auto stream = stub.StreamEnroll(ctx.get());
         stream->WritesDone();
         v1::EnrollViewResponse response;
         while (stream->Read(&response)) {
         }
         return stream->Finish();
       }},
      {"StreamRecognize", TokenRole::kRobot,
       [](const std::shared_ptr<grpc::Channel>& channel) {
         CS stub(channel);
         auto ctx = Ctx();
         auto stream = stub.StreamRecognize(ctx.get());
         stream->WritesDone();
         v1::RecognizeResponse response;
         while (stream->Read(&response)) {
         }
         return stream->Finish();
       }},
      {"CreateSession", TokenRole::kRobot,
       Unary<v1::CreateSessionRequest, v1::Session, SS>(&SS::CreateSession)},
      {"GetMap", TokenRole::kViewer, Unary<v1::GetMapRequest, v1::SegmentMap, SS>(&SS::GetMap)},
      {"GetTrajectory", TokenRole::kViewer,
       Unary<v1::GetTrajectoryRequest, v1::Trajectory, SS>(&SS::GetTrajectory)},
      {"CloseSession", TokenRole::kRobot,
       Unary<v1::CloseSessionRequest, v1::Session, SS>(&SS::CloseSession)},
      {"GetOccupancyGrid", TokenRole::kViewer,
       Unary<v1::GetOccupancyGridRequest, v1::OccupancyGrid, SS>(&SS::GetOccupancyGrid)},
      {"ListSessions", TokenRole::kViewer,
       Unary<v1::ListSessionsRequest, v1::ListSessionsResponse, SS>(&SS::ListSessions)},
      {"DeleteSession", TokenRole::kRobot,
       Unary<v1::DeleteSessionRequest, v1::DeleteSessionResponse, SS>(&SS::DeleteSession)},
      {"CreateMap", TokenRole::kMapper, Unary<v1::CreateMapRequest, v1::Map, SS>(&SS::CreateMap)},
      {"ListMaps", TokenRole::kViewer,
       Unary<v1::ListMapsRequest, v1::ListMapsResponse, SS>(&SS::ListMaps)},
      {"GetMapInfo", TokenRole::kViewer,
       Unary<v1::GetMapInfoRequest, v1::Map, SS>(&SS::GetMapInfo)},
      {"DeleteMap", TokenRole::kMapper,
       Unary<v1::DeleteMapRequest, v1::DeleteMapResponse, SS>(&SS::DeleteMap)},
      {"GetMapOccupancyGrid", TokenRole::kViewer,
       Unary<v1::GetMapOccupancyGridRequest, v1::MapOccupancyGrid, SS>(&SS::GetMapOccupancyGrid)},
      {"GetMapSegments", TokenRole::kViewer,
       Unary<v1::GetMapSegmentsRequest, v1::MapSegmentMap, SS>(&SS::GetMapSegments)},
      {"StreamSensorData", TokenRole::kRobot,
       [](const std::shared_ptr<grpc::Channel>& channel) {
         SS stub(channel);
         auto ctx = Ctx();
         auto stream = stub.StreamSensorData(ctx.get());
         v1::SensorData hello;
         hello.set_session_id("no-such-session");
         stream->Write(hello);
         stream->WritesDone();
         v1::SlamUpdate update;
         while (stream->Read(&update)) {
         }
         return stream->Finish();
       }},
      {"ListTokens", TokenRole::kAdmin,
       Unary<v1::ListTokensRequest, v1::ListTokensResponse, TS>(&TS::ListTokens)},
      {"CreateToken", TokenRole::kAdmin,
       Unary<v1::CreateTokenRequest, v1::CreatedToken, TS>(&TS::CreateToken)},
      {"RevokeToken", TokenRole::kAdmin,
       Unary<v1::RevokeTokenRequest, v1::Token, TS>(&TS::RevokeToken)},
  };
  return rpcs;
}

// viewer < robot < mapper < admin (the live view, the one exception, is not an RPC).
int Rank(TokenRole role) {
  return role == TokenRole::kViewer  ? 0
         : role == TokenRole::kRobot ? 1
         : role == TokenRole::kMapper ? 2
                                      : 3;
}

class AuthTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = new std::string(testing::MakeTempDir("auth"));
    db_ = new std::string(*dir_ + "/waymark.db");
    auto store = storage::OpenSqliteTokenStore(*db_);
    ASSERT_TRUE(store.ok()) << store.status();
    secrets_ = new std::map<std::string, std::string>();
    auto add = [&](const std::string& name, const std::string& robot, TokenRole role,
                   std::optional<double> expires_at = std::nullopt) {
      auto created = (*store)->CreateToken(name, robot, role, expires_at);
      ASSERT_TRUE(created.ok()) << created.status();
      (*secrets_)[name] = created->secret;
    };
    add("r1", "robot-1", TokenRole::kRobot);
    add("r2", "robot-2", TokenRole::kRobot);
    add("m1", "mapper-1", TokenRole::kMapper);
    add("a1", "admin-1", TokenRole::kAdmin);
    add("v1", "viewer-1", TokenRole::kViewer);
    add("expired", "robot-1", TokenRole::kAdmin, storage::NowSeconds() - 60);
    add("revoked", "robot-1", TokenRole::kAdmin);
    ASSERT_TRUE((*store)->RevokeToken("revoked").ok());
    auto server = testing::ServerProcess::StartWithAuth(testing::ServerBinary(), *db_,
                                                        {"--max-streams-per-robot", "1"});
    ASSERT_TRUE(server.ok()) << server.status();
    server_ = server->release();
  }
  static void TearDownTestSuite() {
    delete server_;
    delete secrets_;
    delete db_;
    delete dir_;
  }

  static std::shared_ptr<grpc::Channel> As(const std::string& token_name) {
    client::ChannelOptions options;
    options.bearer_token = token_name.empty() ? "" : secrets_->at(token_name);
    return client::MakeChannel(server_->address(), options);
  }
  static std::shared_ptr<grpc::Channel> WithSecret(const std::string& secret) {
    client::ChannelOptions options;
    options.bearer_token = secret;
    return client::MakeChannel(server_->address(), options);
  }

  static std::string* dir_;
  static std::string* db_;
  static std::map<std::string, std::string>* secrets_;
  static testing::ServerProcess* server_;
};

std::string* AuthTest::dir_ = nullptr;
std::string* AuthTest::db_ = nullptr;
std::map<std::string, std::string>* AuthTest::secrets_ = nullptr;
testing::ServerProcess* AuthTest::server_ = nullptr;

TEST_F(AuthTest, EveryRpcRefusesCallsWithoutAValidToken) {
  const std::vector<std::pair<std::string, std::shared_ptr<grpc::Channel>>> bad = {
      {"no token", As("")},
      {"unknown token", WithSecret("wm_" + std::string(64, '0'))},
      {"expired token", As("expired")},
      {"revoked token", As("revoked")},
  };
  for (const RpcCase& rpc : AllRpcs()) {
    for (const auto& [what, channel] : bad) {
      const grpc::Status status = rpc.call(channel);
      EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAUTHENTICATED)
          << rpc.name << " with " << what << ": " << status.error_message();
    }
  }
}

TEST_F(AuthTest, ExpiredAndRevokedTokensSayWhy) {
  const auto rpc = AllRpcs()[1];  // ListDatabases
  EXPECT_THAT(rpc.call(As("expired")).error_message(), HasSubstr("expired"));
  EXPECT_THAT(rpc.call(As("revoked")).error_message(), HasSubstr("revoked"));
  EXPECT_THAT(rpc.call(As("")).error_message(), HasSubstr("no token"));
}

TEST_F(AuthTest, MalformedAuthorizationHeaderIsUnauthenticated) {
  v1::CrossingService::Stub stub(client::MakeChannel(server_->address()));
  auto ctx = Ctx();
  ctx->AddMetadata("authorization", "Basic dXNlcjpwYXNz");
  v1::ListDatabasesResponse response;
  const grpc::Status status = stub.ListDatabases(ctx.get(), {}, &response);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAUTHENTICATED);
  EXPECT_THAT(status.error_message(), HasSubstr("Bearer"));
}

TEST_F(AuthTest, EachRoleGetsExactlyItsRpcs) {
  const std::vector<std::pair<std::string, TokenRole>> roles = {
      {"v1", TokenRole::kViewer}, {"r1", TokenRole::kRobot}, {"m1", TokenRole::kMapper},
      {"a1", TokenRole::kAdmin}};
  for (const RpcCase& rpc : AllRpcs()) {
    for (const auto& [token, role] : roles) {
      const grpc::Status status = rpc.call(As(token));
      EXPECT_NE(status.error_code(), grpc::StatusCode::UNAUTHENTICATED)
          << rpc.name << " as " << token << ": " << status.error_message();
      if (Rank(role) >= Rank(rpc.needs)) {
        EXPECT_NE(status.error_code(), grpc::StatusCode::PERMISSION_DENIED)
            << rpc.name << " as " << token << ": " << status.error_message();
      } else {
        EXPECT_EQ(status.error_code(), grpc::StatusCode::PERMISSION_DENIED)
            << rpc.name << " as " << token << ": " << status.error_message();
        EXPECT_THAT(status.error_message(), HasSubstr("needs role"));
      }
    }
  }
}

// Issue 21 campaign: token names of any length were stored (an 8 MiB one made ListTokens answer
// 230 MB, which gRPC refused to send).
TEST_F(AuthTest, TokenNamesAndRobotIdsAreBounded) {
  v1::TokenService::Stub admin(As("a1"));
  v1::CreateTokenRequest request;
  request.set_name(std::string(129, 't'));
  request.set_role(v1::ROBOT);
  v1::CreatedToken created;
  grpc::Status status = admin.CreateToken(Ctx().get(), request, &created);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
  EXPECT_NE(status.error_message().find("name is 129 bytes long"), std::string::npos);
  request.set_name("bounded");
  request.set_robot_id(std::string(200, 'r'));
  status = admin.CreateToken(Ctx().get(), request, &created);
  EXPECT_EQ(status.error_code(), grpc::StatusCode::INVALID_ARGUMENT) << status.error_message();
  request.set_robot_id("robot-9");
  EXPECT_TRUE(admin.CreateToken(Ctx().get(), request, &created).ok());
}

TEST_F(AuthTest, HealthNeedsNoToken) {
  auto status = client::CheckHealth(As(""), "", absl::Seconds(10));
  ASSERT_TRUE(status.ok()) << status.status();
  EXPECT_EQ(*status, grpc::health::v1::HealthCheckResponse::SERVING);
}

TEST_F(AuthTest, RobotsOnlySeeAndFeedTheirOwnSessions) {
  v1::SlamService::Stub robot1(As("r1"));
  v1::SlamService::Stub robot2(As("r2"));
  v1::SlamService::Stub admin(As("a1"));
  v1::SlamService::Stub mapper(As("m1"));

  // A robot's token fills in its robot id; naming another robot is refused.
  v1::CreateSessionRequest request = testing::TestSessionRequest("");
  v1::Session session;
  ASSERT_TRUE(robot1.CreateSession(Ctx().get(), request, &session).ok());
  EXPECT_EQ(session.robot_id(), "robot-1");
  v1::Session stolen;
  const grpc::Status impersonate =
      robot2.CreateSession(Ctx().get(), testing::TestSessionRequest("robot-1"), &stolen);
  EXPECT_EQ(impersonate.error_code(), grpc::StatusCode::PERMISSION_DENIED);

  const std::string id = session.session_id();
  v1::GetMapRequest map_request;
  map_request.set_session_id(id);
  v1::SegmentMap map;
  EXPECT_TRUE(robot1.GetMap(Ctx().get(), map_request, &map).ok());
  EXPECT_EQ(robot2.GetMap(Ctx().get(), map_request, &map).error_code(),
            grpc::StatusCode::PERMISSION_DENIED);
  EXPECT_EQ(mapper.GetMap(Ctx().get(), map_request, &map).error_code(),
            grpc::StatusCode::PERMISSION_DENIED);
  EXPECT_TRUE(admin.GetMap(Ctx().get(), map_request, &map).ok());
  v1::GetTrajectoryRequest trajectory_request;
  trajectory_request.set_session_id(id);
  v1::Trajectory trajectory;
  EXPECT_EQ(robot2.GetTrajectory(Ctx().get(), trajectory_request, &trajectory).error_code(),
            grpc::StatusCode::PERMISSION_DENIED);

  // Streaming into another robot's session ends the stream before any data is taken.
  {
    auto ctx = Ctx();
    auto stream = robot2.StreamSensorData(ctx.get());
    v1::SensorData hello;
    hello.set_session_id(id);
    stream->Write(hello);
    stream->WritesDone();
    v1::SlamUpdate update;
    while (stream->Read(&update)) {
    }
    const grpc::Status status = stream->Finish();
    EXPECT_EQ(status.error_code(), grpc::StatusCode::PERMISSION_DENIED) << status.error_message();
    EXPECT_THAT(status.error_message(), HasSubstr("robot-1"));
  }

  // Listing: a robot sees only its own sessions, and may not ask for another robot's.
  v1::ListSessionsResponse list;
  ASSERT_TRUE(robot2.ListSessions(Ctx().get(), {}, &list).ok());
  for (const v1::Session& s : list.sessions()) EXPECT_EQ(s.robot_id(), "robot-2");
  v1::ListSessionsRequest other;
  other.set_robot_id("robot-1");
  EXPECT_EQ(robot2.ListSessions(Ctx().get(), other, &list).error_code(),
            grpc::StatusCode::PERMISSION_DENIED);
  ASSERT_TRUE(admin.ListSessions(Ctx().get(), {}, &list).ok());
  bool admin_sees_it = false;
  for (const v1::Session& s : list.sessions()) admin_sees_it |= s.session_id() == id;
  EXPECT_TRUE(admin_sees_it);

  v1::CloseSessionRequest close;
  close.set_session_id(id);
  v1::Session closed;
  EXPECT_EQ(robot2.CloseSession(Ctx().get(), close, &closed).error_code(),
            grpc::StatusCode::PERMISSION_DENIED);
  EXPECT_TRUE(robot1.CloseSession(Ctx().get(), close, &closed).ok());

  // Deleting follows the same rule as closing: not another robot's session.
  v1::DeleteSessionRequest remove;
  remove.set_session_id(id);
  v1::DeleteSessionResponse deleted;
  EXPECT_EQ(robot2.DeleteSession(Ctx().get(), remove, &deleted).error_code(),
            grpc::StatusCode::PERMISSION_DENIED);
  EXPECT_TRUE(robot1.DeleteSession(Ctx().get(), remove, &deleted).ok());
  EXPECT_EQ(deleted.session().session_id(), id);
}

TEST_F(AuthTest, StreamsPerRobotAreCapped) {
  // The server runs with --max-streams-per-robot 1. Robot 1 holds a sensor stream; the rejection
  // of a malformed message proves the server is past the stream's admission.
  v1::SlamService::Stub slam(As("r1"));
  v1::Session session;
  ASSERT_TRUE(slam.CreateSession(Ctx().get(), testing::TestSessionRequest(""), &session).ok());
  auto held_ctx = Ctx();
  auto held = slam.StreamSensorData(held_ctx.get());
  v1::SensorData bad;
  bad.set_session_id(session.session_id());
  bad.set_sequence(1);
  bad.mutable_odometry()->set_stamp(std::numeric_limits<double>::quiet_NaN());
  ASSERT_TRUE(held->Write(bad));
  v1::SlamUpdate rejection;
  ASSERT_TRUE(held->Read(&rejection));
  ASSERT_TRUE(rejection.has_rejection());

  // A second stream of the same robot, of any kind, is refused.
  v1::CrossingService::Stub robot1(As("r1"));
  v1::RecognizeResponse answer;
  auto second_ctx = Ctx();
  auto second = robot1.StreamRecognize(second_ctx.get());
  second->WritesDone();
  while (second->Read(&answer)) {
  }
  const grpc::Status refused = second->Finish();
  EXPECT_EQ(refused.error_code(), grpc::StatusCode::RESOURCE_EXHAUSTED) << refused.error_message();
  EXPECT_THAT(refused.error_message(), HasSubstr("--max-streams-per-robot"));

  // Another robot has its own slot.
  v1::CrossingService::Stub robot2(As("r2"));
  auto other_ctx = Ctx();
  auto other = robot2.StreamRecognize(other_ctx.get());
  other->WritesDone();
  while (other->Read(&answer)) {
  }
  const grpc::Status other_status = other->Finish();
  EXPECT_TRUE(other_status.ok()) << other_status.error_message();

  held->WritesDone();
  while (held->Read(&rejection)) {
  }
  EXPECT_TRUE(held->Finish().ok());
  // The slot is free again once the stream ended.
  auto third_ctx = Ctx();
  auto third = robot1.StreamRecognize(third_ctx.get());
  third->WritesDone();
  while (third->Read(&answer)) {
  }
  const grpc::Status third_status = third->Finish();
  EXPECT_TRUE(third_status.ok()) << third_status.error_message();
}

TEST_F(AuthTest, AdminManagesTokensThroughTheApiAndRevocationIsImmediate) {
  const std::string at = "--server " + server_->address() + " --token " + secrets_->at("a1");
  testing::CommandResult created =
      testing::RunBinary("waymark", at + " token create robot-9 --role robot", false);
  ASSERT_EQ(created.code, 0) << created.output;
  const std::string secret = created.output.substr(0, created.output.find('\n'));
  ASSERT_THAT(secret, ::testing::StartsWith("wm_"));

  const std::string as_new = "--server " + server_->address() + " --token " + secret;
  testing::CommandResult listed = testing::RunBinary("waymark", as_new + " db list");
  EXPECT_EQ(listed.code, 0) << listed.output;
  testing::CommandResult denied = testing::RunBinary("waymark", as_new + " token list");
  EXPECT_EQ(denied.code, 1);
  EXPECT_THAT(denied.output, HasSubstr("PERMISSION_DENIED"));

  testing::CommandResult list = testing::RunBinary("waymark", at + " token list");
  EXPECT_EQ(list.code, 0) << list.output;
  EXPECT_THAT(list.output, HasSubstr("robot-9"));
  EXPECT_THAT(list.output, ::testing::Not(HasSubstr(secret))) << "secrets are never listed";

  testing::CommandResult revoked = testing::RunBinary("waymark", at + " token revoke robot-9");
  EXPECT_EQ(revoked.code, 0) << revoked.output;
  testing::CommandResult after = testing::RunBinary("waymark", as_new + " db list");
  EXPECT_EQ(after.code, 1);
  EXPECT_THAT(after.output, HasSubstr("UNAUTHENTICATED"));
}

// A stream opened with a token that is then revoked (through this server's API, or in the
// database by another process) or that expires is ended by the server with UNAUTHENTICATED. The
// client's deadline is far beyond the server's checks: a stream the server leaves open ends with
// DEADLINE_EXCEEDED instead, and the test fails.
TEST_F(AuthTest, OpenStreamsEndWhenTheirTokenIsRevokedOrExpires) {
  auto store = storage::OpenSqliteTokenStore(*db_);
  ASSERT_TRUE(store.ok()) << store.status();
  const auto open_stream = [&](const std::string& secret, grpc::ClientContext* ctx) {
    v1::SlamService::Stub slam(WithSecret(secret));
    v1::Session session;
    EXPECT_TRUE(slam.CreateSession(Ctx().get(), testing::TestSessionRequest(""), &session).ok());
    auto stream = slam.StreamSensorData(ctx);
    // A malformed message's rejection proves the stream is past its admission.
    v1::SensorData bad;
    bad.set_session_id(session.session_id());
    bad.set_sequence(1);
    bad.mutable_odometry()->set_stamp(std::numeric_limits<double>::quiet_NaN());
    EXPECT_TRUE(stream->Write(bad));
    v1::SlamUpdate rejection;
    EXPECT_TRUE(stream->Read(&rejection));
    EXPECT_TRUE(rejection.has_rejection());
    return stream;
  };
  const auto ended_status = [](auto& stream) {
    v1::SlamUpdate update;
    while (stream->Read(&update)) {
    }
    return stream->Finish();
  };
  const auto long_ctx = [] {
    auto ctx = std::make_unique<grpc::ClientContext>();
    ctx->set_deadline(std::chrono::system_clock::now() + std::chrono::seconds(60));
    return ctx;
  };
  v1::TokenService::Stub admin(As("a1"));

  {  // Revoked through the API.
    auto created = (*store)->CreateToken("stream-api", "robot-71", TokenRole::kRobot, std::nullopt);
    ASSERT_TRUE(created.ok()) << created.status();
    auto ctx = long_ctx();
    auto stream = open_stream(created->secret, ctx.get());
    v1::RevokeTokenRequest revoke;
    revoke.set_name("stream-api");
    v1::Token revoked;
    ASSERT_TRUE(admin.RevokeToken(Ctx().get(), revoke, &revoked).ok());
    const grpc::Status status = ended_status(stream);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAUTHENTICATED) << status.error_message();
  }
  {  // Revoked in the database by another process (the server's cache holds it for 5 s).
    auto created = (*store)->CreateToken("stream-db", "robot-72", TokenRole::kRobot, std::nullopt);
    ASSERT_TRUE(created.ok()) << created.status();
    auto ctx = long_ctx();
    auto stream = open_stream(created->secret, ctx.get());
    ASSERT_TRUE((*store)->RevokeToken("stream-db").ok());
    const grpc::Status status = ended_status(stream);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAUTHENTICATED) << status.error_message();
  }
  {  // Expired while streaming.
    auto created = (*store)->CreateToken("stream-expiring", "robot-73", TokenRole::kRobot,
                                         storage::NowSeconds() + 2);
    ASSERT_TRUE(created.ok()) << created.status();
    auto ctx = long_ctx();
    auto stream = open_stream(created->secret, ctx.get());
    const grpc::Status status = ended_status(stream);
    EXPECT_EQ(status.error_code(), grpc::StatusCode::UNAUTHENTICATED) << status.error_message();
  }
  // A token still valid keeps its stream: it ends when the client ends it, with OK.
  auto ctx = long_ctx();
  auto stream = open_stream(secrets_->at("r2"), ctx.get());
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));  // past a revalidation
  stream->WritesDone();
  EXPECT_TRUE(ended_status(stream).ok());
}

TEST_F(AuthTest, ServerTokenCommandWorksOnTheDatabaseWhileServing) {
  testing::CommandResult created = testing::RunBinary(
      "waymark-server", "--db " + *db_ + " token create local-admin --role admin", false);
  ASSERT_EQ(created.code, 0) << created.output;
  const std::string secret = created.output.substr(0, created.output.find('\n'));
  testing::CommandResult used = testing::RunBinary(
      "waymark", "--server " + server_->address() + " --token " + secret + " token list");
  EXPECT_EQ(used.code, 0) << used.output;
  EXPECT_THAT(used.output, HasSubstr("local-admin"));
  testing::CommandResult bad_role = testing::RunBinary(
      "waymark-server", "--db " + *db_ + " token create x --role superuser");
  EXPECT_NE(bad_role.code, 0);
  EXPECT_THAT(bad_role.output, HasSubstr("robot, mapper, admin or viewer"));
}

}  // namespace
}  // namespace waymark
