// `waymark bench load` without a server: the address checks, finding a listening process, its
// memory and CPU time through /proc (a fake tree and the real one), the recorder's summary, and
// the bounds and loopback refusals of the command line (which come before any connection).

#include <arpa/inet.h>
#include <gmock/gmock.h>
#include <gtest/gtest.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "client/load/load_stats.h"
#include "client/cli/server_address.h"
#include "client/load/server_usage.h"
#include "tests/client/test_util.h"

namespace waymark::cli {
namespace {

using ::testing::HasSubstr;
using waymark::testing::RunWaymark;
using waymark::testing::ScopedTempDir;

TEST(ServerAddressTest, ParsesTheTargetFormsOfTheCommandLine) {
  EXPECT_EQ(ParseHostPort("127.0.0.1:50051")->port, 50051);
  EXPECT_EQ(ParseHostPort("127.0.0.1:50051")->host, "127.0.0.1");
  EXPECT_EQ(ParseHostPort("[::1]:7")->host, "::1");
  EXPECT_EQ(ParseHostPort("ipv6:[::1]:7")->port, 7);
  EXPECT_EQ(ParseHostPort("dns:///localhost:9")->host, "localhost");
  EXPECT_EQ(ParseHostPort("ipv4:10.0.0.2:9")->host, "10.0.0.2");
  EXPECT_FALSE(ParseHostPort("localhost"));
  EXPECT_FALSE(ParseHostPort("::1:50051"));  // IPv6 needs brackets
  EXPECT_FALSE(ParseHostPort("host:0"));
  EXPECT_FALSE(ParseHostPort("host:70000"));
  EXPECT_FALSE(ParseHostPort("unix:/run/waymark.sock"));
  EXPECT_FALSE(ParseHostPort("ipv4:127.0.0.1:1,127.0.0.1:2"));
}

TEST(ServerAddressTest, OnlyThisMachineIsLoopback) {
  for (const char* local :
       {"127.0.0.1:50051", "127.1.2.3:1", "localhost:50051", "LocalHost:1", "[::1]:50051",
        "ipv4:127.0.0.1:5", "dns:///localhost:5", "unix:/tmp/waymark.sock"}) {
    EXPECT_TRUE(IsLoopbackTarget(local)) << local;
  }
  for (const char* remote : {"10.0.0.5:50051", "0.0.0.0:50051", "[::]:50051", "robot.lab:50051",
                             "128.0.0.1:1", "localhost.example.com:1", "127.0.0.1"}) {
    EXPECT_FALSE(IsLoopbackTarget(remote)) << remote;
  }
}

// A /proc tree with one listening socket on port 50001 (0xC351) held by process 4321.
TEST(ServerUsageTest, FindsTheListeningProcessAndItsMemoryInAFakeProc) {
  ScopedTempDir proc;
  std::ofstream(proc.Make("net/tcp"))
      << "  sl  local_address rem_address   st tx_queue rx_queue tr tm->when retrnsmt   uid  "
         "timeout inode\n"
      << "   0: 0100007F:C351 00000000:0000 0A 00000000:00000000 00:00000000 00000000     0  "
         "      0 4242 1 0000000000000000 100 0 0 10 0\n"
      << "   1: 0100007F:C352 0100007F:C351 01 00000000:00000000 00:00000000 00000000     0  "
         "      0 5555 1 0000000000000000 100 0 0 10 0\n";
  std::ofstream(proc.Make("net/tcp6")) << "  sl  local_address ...\n";
  std::filesystem::create_directories(proc.path() / "4321" / "fd");
  std::filesystem::create_directories(proc.path() / "99" / "fd");
  std::filesystem::create_symlink("socket:[5555]", proc.path() / "99" / "fd" / "3");
  std::filesystem::create_symlink("socket:[4242]", proc.path() / "4321" / "fd" / "7");
  std::ofstream(proc.Make("4321/status")) << "Name:\twaymark-server\nVmHWM:\t  204800 kB\n"
                                          << "VmRSS:\t  102400 kB\nThreads:\t12\n";

  absl::StatusOr<pid_t> pid = FindListeningProcess(50001, proc.path().string());
  ASSERT_TRUE(pid.ok()) << pid.status();
  EXPECT_EQ(*pid, 4321);
  // Port 50002 only has a connected (not listening) socket.
  EXPECT_EQ(FindListeningProcess(50002, proc.path().string()).status().code(),
            absl::StatusCode::kNotFound);

  absl::StatusOr<ProcessMemory> memory = ReadProcessMemory(4321, proc.path().string());
  ASSERT_TRUE(memory.ok()) << memory.status();
  EXPECT_EQ(memory->rss_bytes, 100 * 1024 * 1024);
  EXPECT_EQ(memory->peak_rss_bytes, 200 * 1024 * 1024);
  EXPECT_EQ(ReadProcessMemory(1234, proc.path().string()).status().code(),
            absl::StatusCode::kNotFound);

  // A command name with spaces and parentheses; utime 250 and stime 50 ticks.
  std::ofstream(proc.Make("4321/stat"))
      << "4321 (waymark (x) server) S 1 4321 4321 0 -1 4194560 2000 0 0 0 250 50 0 0 20 0 12 0\n";
  absl::StatusOr<double> cpu = ReadProcessCpuSeconds(4321, proc.path().string());
  ASSERT_TRUE(cpu.ok()) << cpu.status();
  EXPECT_DOUBLE_EQ(*cpu, 300.0 / sysconf(_SC_CLK_TCK));
  EXPECT_EQ(ReadProcessCpuSeconds(1234, proc.path().string()).status().code(),
            absl::StatusCode::kNotFound);
}

TEST(ServerUsageTest, FindsThisProcessListeningOnARealPort) {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  ASSERT_GE(fd, 0);
  sockaddr_in address{};
  address.sin_family = AF_INET;
  address.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  ASSERT_EQ(bind(fd, reinterpret_cast<sockaddr*>(&address), sizeof(address)), 0);
  ASSERT_EQ(listen(fd, 1), 0);
  socklen_t length = sizeof(address);
  ASSERT_EQ(getsockname(fd, reinterpret_cast<sockaddr*>(&address), &length), 0);
  absl::StatusOr<pid_t> pid = FindListeningProcess(ntohs(address.sin_port));
  close(fd);
  ASSERT_TRUE(pid.ok()) << pid.status();
  EXPECT_EQ(*pid, getpid());
  absl::StatusOr<ProcessMemory> memory = ReadProcessMemory(getpid());
  ASSERT_TRUE(memory.ok()) << memory.status();
  EXPECT_GT(memory->rss_bytes, 0);
  EXPECT_GE(memory->peak_rss_bytes, memory->rss_bytes);
  absl::StatusOr<double> cpu = ReadProcessCpuSeconds(getpid());
  ASSERT_TRUE(cpu.ok()) << cpu.status();
  EXPECT_GE(*cpu, 0);
}

TEST(LoadRecorderTest, SummarisesCallsLatenciesAndErrorsPerRpc) {
  LoadRecorder recorder;
  for (int i = 1; i <= 100; ++i) {
    recorder.Sent("Recognize");
    recorder.Answered("Recognize", i);
  }
  recorder.Sent("Recognize", 2);
  recorder.Failed("Recognize", absl::StatusCode::kResourceExhausted);
  recorder.Failed("Recognize", absl::StatusCode::kUnavailable);
  recorder.Sent("Stream", 10);  // messages, none answered
  EXPECT_EQ(recorder.Totals().calls, 112);
  EXPECT_EQ(recorder.Totals().failed, 2);

  const std::map<std::string, RpcSummary> rpcs = recorder.Summarize(4.0);
  const RpcSummary& recognize = rpcs.at("Recognize");
  EXPECT_EQ(recognize.calls, 102);
  EXPECT_EQ(recognize.answered, 100);
  EXPECT_EQ(recognize.failed, 2);
  EXPECT_DOUBLE_EQ(recognize.per_second, 25.5);
  EXPECT_DOUBLE_EQ(*recognize.p50_ms, 50.5);
  EXPECT_NEAR(*recognize.p99_ms, 99.01, 1e-9);
  EXPECT_DOUBLE_EQ(*recognize.max_ms, 100);
  EXPECT_EQ(recognize.errors,
            (std::map<std::string, int64_t>{{"RESOURCE_EXHAUSTED", 1}, {"UNAVAILABLE", 1}}));
  EXPECT_FALSE(rpcs.at("Stream").p50_ms.has_value());
  EXPECT_EQ(ErrorsByCode(rpcs).at("UNAVAILABLE"), 1);

  const nlohmann::json json = RpcSummariesJson(rpcs);
  EXPECT_EQ(json["Recognize"]["errors"]["RESOURCE_EXHAUSTED"], 1);
  EXPECT_TRUE(json["Stream"]["latency_ms"]["p50"].is_null());
  std::ostringstream table;
  PrintRpcTable(table, rpcs);
  EXPECT_THAT(table.str(), HasSubstr("RESOURCE_EXHAUSTED 1, UNAVAILABLE 1"));
}

TEST(BenchLoadCommandTest, RefusesOutOfBoundsRunsAndRemoteServers) {
  // Nothing listens on these addresses: each refusal must come before any connection.
  const std::string local = "127.0.0.1:1";
  for (const std::vector<std::string>& args : std::vector<std::vector<std::string>>{
           {"--robots", "201", "--duration", "3"},
           {"--robots", "0", "--duration", "3"},
           {"--robots", "3", "--duration", "3601"},
           {"--robots", "3", "--duration", "0"},
           {"--robots", "3"},
           {"--robots", "3", "--duration", "3", "--scan-hz", "1000"}}) {
    std::vector<std::string> command = {"bench", "load"};
    command.insert(command.end(), args.begin(), args.end());
    const waymark::testing::CliResult result = RunWaymark(local, command);
    EXPECT_NE(result.code, 0) << ::testing::PrintToString(args);
    EXPECT_THAT(result.err, ::testing::AnyOf(HasSubstr("not in"), HasSubstr("required"),
                                             HasSubstr("--duration")))
        << result.err;
  }
  for (const char* remote : {"10.1.2.3:50051", "robot.lab:50051"}) {
    const waymark::testing::CliResult result =
        RunWaymark(remote, {"bench", "load", "--robots", "1", "--duration", "1"});
    EXPECT_EQ(result.code, 1);
    EXPECT_THAT(result.err, HasSubstr("INVALID_ARGUMENT: bench load only runs against a server "
                                      "on this machine"));
    EXPECT_THAT(result.err, HasSubstr(remote));
  }
}

}  // namespace
}  // namespace waymark::cli
