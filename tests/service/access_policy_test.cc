// The role table, robot isolation, the per-robot stream cap and the server's plaintext/TLS rules.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <memory>
#include <vector>

#include "server/service/auth/access_policy.h"
#include "server/service/auth/server_security.h"
#include "server/service/runtime/stream_limiter.h"

namespace waymark::service {
namespace {

using storage::TokenRole;
using ::testing::HasSubstr;

Caller Token(TokenRole role, const std::string& robot) {
  Caller caller;
  caller.token_name = robot + "-token";
  caller.robot_id = robot;
  caller.role = role;
  return caller;
}

TEST(AccessPolicyTest, EachRoleMayDoExactlyItsActions) {
  const std::vector<Action> all = {Action::kReadCrossings, Action::kRecognize,
                                   Action::kEditCrossings, Action::kDeleteDatabase,
                                   Action::kWatchSlam,     Action::kSlam,
                                   Action::kManageTokens,  Action::kLiveView,
                                   Action::kReadMaps,      Action::kEditMaps};
  const std::vector<Action> viewer = {Action::kWatchSlam, Action::kLiveView, Action::kReadMaps};
  const std::vector<Action> robot = {Action::kReadCrossings, Action::kRecognize,
                                     Action::kWatchSlam, Action::kSlam, Action::kReadMaps};
  const std::vector<Action> mapper = {Action::kReadCrossings, Action::kRecognize,
                                      Action::kWatchSlam, Action::kSlam, Action::kEditCrossings,
                                      Action::kReadMaps, Action::kEditMaps};
  for (Action action : all) {
    const bool viewer_may = std::count(viewer.begin(), viewer.end(), action) > 0;
    const bool robot_may = std::count(robot.begin(), robot.end(), action) > 0;
    const bool mapper_may = std::count(mapper.begin(), mapper.end(), action) > 0;
    EXPECT_EQ(CheckAction(Token(TokenRole::kViewer, "v1"), action).ok(), viewer_may)
        << ActionName(action);
    EXPECT_EQ(CheckAction(Token(TokenRole::kRobot, "r1"), action).ok(), robot_may)
        << ActionName(action);
    EXPECT_EQ(CheckAction(Token(TokenRole::kMapper, "m1"), action).ok(), mapper_may)
        << ActionName(action);
    EXPECT_TRUE(CheckAction(Token(TokenRole::kAdmin, "a1"), action).ok()) << ActionName(action);
    Caller dev;
    dev.auth_off = true;
    EXPECT_TRUE(CheckAction(dev, action).ok());
  }
}

TEST(AccessPolicyTest, RefusalNamesTheCallerTheActionAndTheRoleNeeded) {
  absl::Status denied = CheckAction(Token(TokenRole::kRobot, "r1"), Action::kEditCrossings);
  EXPECT_EQ(denied.code(), absl::StatusCode::kPermissionDenied);
  EXPECT_THAT(denied.message(), HasSubstr("r1-token"));
  EXPECT_THAT(denied.message(), HasSubstr("edit crossing databases"));
  EXPECT_THAT(denied.message(), HasSubstr("needs role mapper"));
}

TEST(AccessPolicyTest, RobotsSeeOnlyTheirOwnSessionsAdminsAll) {
  EXPECT_TRUE(CheckRobot(Token(TokenRole::kRobot, "r1"), "r1").ok());
  absl::Status other = CheckRobot(Token(TokenRole::kRobot, "r1"), "r2");
  EXPECT_EQ(other.code(), absl::StatusCode::kPermissionDenied);
  EXPECT_THAT(other.message(), HasSubstr("\"r2\""));
  EXPECT_EQ(CheckRobot(Token(TokenRole::kMapper, "m1"), "r2").code(),
            absl::StatusCode::kPermissionDenied);
  EXPECT_TRUE(CheckRobot(Token(TokenRole::kAdmin, "a1"), "r2").ok());
  EXPECT_FALSE(SeesAllRobots(Token(TokenRole::kMapper, "m1")));
  EXPECT_TRUE(SeesAllRobots(Token(TokenRole::kAdmin, "a1")));
}

// A viewer watches every robot, read-only; the live view is for viewers and admins only (a robot's
// token must not show the fleet).
TEST(AccessPolicyTest, ViewersWatchEveryRobotAndOnlyWatch) {
  const Caller viewer = Token(TokenRole::kViewer, "v1");
  EXPECT_TRUE(SeesAllRobots(viewer));
  EXPECT_TRUE(CheckAction(viewer, Action::kWatchSlam).ok());
  EXPECT_TRUE(CheckAction(viewer, Action::kLiveView).ok());
  const absl::Status stream = CheckAction(viewer, Action::kSlam);
  EXPECT_EQ(stream.code(), absl::StatusCode::kPermissionDenied);
  EXPECT_THAT(stream.message(), HasSubstr("needs role robot"));
  const absl::Status live = CheckAction(Token(TokenRole::kRobot, "r1"), Action::kLiveView);
  EXPECT_EQ(live.code(), absl::StatusCode::kPermissionDenied);
  EXPECT_THAT(live.message(), HasSubstr("viewer"));
  EXPECT_FALSE(CheckAction(Token(TokenRole::kMapper, "m1"), Action::kLiveView).ok());
  EXPECT_TRUE(CheckAction(Token(TokenRole::kAdmin, "a1"), Action::kLiveView).ok());
}

TEST(StreamLimiterTest, CapsStreamsPerRobotAndReleasesOnDestruction) {
  StreamLimiter limiter(2);
  auto a = limiter.Acquire("r1");
  auto b = limiter.Acquire("r1");
  ASSERT_TRUE(a.ok() && b.ok());
  auto c = limiter.Acquire("r1");
  EXPECT_EQ(c.status().code(), absl::StatusCode::kResourceExhausted);
  EXPECT_THAT(c.status().message(), HasSubstr("--max-streams-per-robot"));
  EXPECT_TRUE(limiter.Acquire("r2").ok()) << "another robot has its own slots";
  EXPECT_EQ(limiter.Open("r1"), 2);
  a->reset();
  EXPECT_EQ(limiter.Open("r1"), 1);
  EXPECT_TRUE(limiter.Acquire("r1").ok());
}

TEST(StreamLimiterTest, ZeroMeansNoLimit) {
  StreamLimiter limiter(0);
  std::vector<std::unique_ptr<StreamLimiter::Lease>> leases;
  for (int i = 0; i < 100; ++i) {
    auto lease = limiter.Acquire("r1");
    ASSERT_TRUE(lease.ok());
    leases.push_back(std::move(*lease));
  }
  EXPECT_EQ(limiter.Open("r1"), 100);
}

TEST(ServerSecurityTest, LoopbackAddresses) {
  EXPECT_TRUE(IsLoopbackListen("127.0.0.1:50051"));
  EXPECT_TRUE(IsLoopbackListen("127.0.0.2:0"));
  EXPECT_TRUE(IsLoopbackListen("localhost:50051"));
  EXPECT_TRUE(IsLoopbackListen("[::1]:50051"));
  EXPECT_TRUE(IsLoopbackListen("unix:/tmp/waymark.sock"));
  EXPECT_FALSE(IsLoopbackListen("0.0.0.0:50051"));
  EXPECT_FALSE(IsLoopbackListen("[::]:50051"));
  EXPECT_FALSE(IsLoopbackListen("192.168.1.5:50051"));
  EXPECT_FALSE(IsLoopbackListen("128.0.0.1:50051"));
}

TEST(ServerSecurityTest, RefusesUnsafeSetups) {
  SecurityOptions dev;
  dev.insecure_dev = true;
  EXPECT_TRUE(MakeServerCredentials("127.0.0.1:0", dev).ok());
  auto remote_dev = MakeServerCredentials("0.0.0.0:50051", dev);
  EXPECT_EQ(remote_dev.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(remote_dev.status().message(), HasSubstr("loopback"));

  SecurityOptions plain;
  auto remote_plain = MakeServerCredentials("0.0.0.0:50051", plain);
  EXPECT_EQ(remote_plain.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_THAT(remote_plain.status().message(), HasSubstr("--allow-plaintext"));
  plain.allow_plaintext = true;
  EXPECT_TRUE(MakeServerCredentials("0.0.0.0:50051", plain).ok());

  SecurityOptions half;
  half.tls_cert = "/nonexistent/cert.pem";
  EXPECT_EQ(MakeServerCredentials("0.0.0.0:50051", half).status().code(),
            absl::StatusCode::kFailedPrecondition);
  half.tls_key = "/nonexistent/key.pem";
  auto missing = MakeServerCredentials("0.0.0.0:50051", half);
  EXPECT_EQ(missing.status().code(), absl::StatusCode::kNotFound);
  EXPECT_THAT(missing.status().message(), HasSubstr("/nonexistent/cert.pem"));

  SecurityOptions client_ca_only;
  client_ca_only.tls_client_ca = "/tmp/ca.pem";
  EXPECT_EQ(MakeServerCredentials("127.0.0.1:0", client_ca_only).status().code(),
            absl::StatusCode::kFailedPrecondition);
}

}  // namespace
}  // namespace waymark::service
