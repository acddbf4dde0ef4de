// `waymark bench load` against the real server: a short run of 3 robots completes with calls on
// every RPC, no errors, every session closed, the server's memory and CPU found through its port,
// and the database it created deleted again.

#include <gmock/gmock.h>
#include <gtest/gtest.h>

#include <csignal>
#include <filesystem>
#include <string>

#include "tests/client/test_util.h"
#include "tests/support/server_process.h"

namespace waymark {
namespace {

TEST(BenchLoadTest, ThreeRobotsForThreeSecondsWithoutErrors) {
  const std::string dir = testing::MakeTempDir("bench-load");
  auto server = testing::ServerProcess::Start(testing::ServerBinary(), dir + "/waymark.db");
  ASSERT_TRUE(server.ok()) << server.status();

  const testing::CliResult run = testing::RunWaymark(
      (*server)->address(), {"--json", "bench", "load", "--robots", "3", "--duration", "3"});
  ASSERT_EQ(run.code, 0) << run.err << run.out;
  const nlohmann::json report = run.Json();
  EXPECT_EQ(report["robots"], 3);
  EXPECT_EQ(report["errors"]["total"], 0) << report.dump(2);
  EXPECT_GT(report["database"]["views_enrolled"].get<int>(), 0);

  const nlohmann::json& rpcs = report["rpcs"];
  for (const char* rpc : {"RecognizeCrossing", "StreamSensorData"}) {
    EXPECT_GT(rpcs[rpc]["calls"].get<int>(), 0) << rpc;
    EXPECT_GT(rpcs[rpc]["answered"].get<int>(), 0) << rpc;
    EXPECT_GT(rpcs[rpc]["per_s"].get<double>(), 0) << rpc;
    EXPECT_GE(rpcs[rpc]["latency_ms"]["p99"].get<double>(),
              rpcs[rpc]["latency_ms"]["p50"].get<double>())
        << rpc;
  }
  EXPECT_EQ(rpcs["CreateSession"]["answered"], 3);
  EXPECT_EQ(rpcs["CloseSession"]["answered"], 3);
  EXPECT_EQ(report["slam"]["sessions_closed"], 3);
  // Every scan sent was answered by the end of the run (the stream is finished, not dropped).
  EXPECT_EQ(report["slam"]["scans_answered"], report["slam"]["scans_sent"]);
  EXPECT_EQ(rpcs["StreamSensorData"]["answered"], report["slam"]["scans_answered"]);

  const nlohmann::json& process = report["server_process"];
  EXPECT_EQ(process["pid"], (*server)->pid()) << process.dump();
  EXPECT_GT(process["rss_peak_mib"].get<double>(), 0);
  EXPECT_GT(process["cpu_s"].get<double>(), 0);

  // Progress went to stderr once a second; the created database is gone.
  EXPECT_THAT(run.err, ::testing::HasSubstr("3 robots:"));
  const testing::CliResult list =
      testing::RunWaymark((*server)->address(), {"--json", "db", "list"});
  ASSERT_EQ(list.code, 0) << list.err;
  EXPECT_THAT(list.out, ::testing::Not(::testing::HasSubstr("bench-load-")));

  EXPECT_EQ((*server)->Stop(SIGTERM), 0);
  if (!HasFailure()) std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace waymark
