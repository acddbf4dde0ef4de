// `waymark health` against the real server binary: what a container HEALTHCHECK runs.
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <csignal>
#include <cstdio>
#include <string>

#include "tests/support/server_process.h"

namespace waymark {
namespace {

using ::testing::HasSubstr;

struct Result {
  int code = -1;
  std::string output;  // stdout and stderr
};

Result RunWaymark(const std::string& args) {
  const std::string command = std::string(WAYMARK_BINARY_DIR) + "/bin/waymark " + args + " 2>&1";
  Result r;
  FILE* pipe = popen(command.c_str(), "r");
  if (pipe == nullptr) return r;
  char buffer[4096];
  size_t n;
  while ((n = fread(buffer, 1, sizeof(buffer), pipe)) > 0) r.output.append(buffer, n);
  const int status = pclose(pipe);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

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
