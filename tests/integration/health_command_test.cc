// `waymark health` against the real server binary: what a container HEALTHCHECK runs.
#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <csignal>
#include <string>

#include "tests/support/server_process.h"

namespace waymark {
namespace {

using ::testing::HasSubstr;

using Result = testing::CommandResult;

Result RunWaymark(const std::string& args) { return testing::RunBinary("waymark", args); }

TEST(HealthCommandTest, ServingServerUnknownServiceAndNoServer) {
  const std::string dir = testing::MakeTempDir("health");
  auto server = testing::ServerProcess::Start(testing::ServerBinary(), dir + "/waymark.db");
  ASSERT_TRUE(server.ok()) << server.status();
  const std::string at = "--server " + (*server)->address();

  Result whole = RunWaymark(at + " health");
  EXPECT_EQ(whole.code, 0) << whole.output;
  EXPECT_EQ(whole.output, "SERVING\n");
  Result slam = RunWaymark(at + " health --service waymark.v1.SlamService --json");
  EXPECT_EQ(slam.code, 0) << slam.output;
  EXPECT_THAT(slam.output, HasSubstr("\"serving\": true"));
  Result unknown = RunWaymark(at + " health --service waymark.v1.Nope");
  EXPECT_EQ(unknown.code, 1);
  EXPECT_THAT(unknown.output, HasSubstr("NOT_FOUND"));

  const std::string address = (*server)->address();
  EXPECT_EQ((*server)->Stop(SIGTERM), 0);
  Result down = RunWaymark("--server " + address + " --timeout 2 health");
  EXPECT_EQ(down.code, 1);
  EXPECT_THAT(down.output,
              ::testing::AnyOf(HasSubstr("UNAVAILABLE"), HasSubstr("DEADLINE_EXCEEDED")));
}

}  // namespace
}  // namespace waymark
