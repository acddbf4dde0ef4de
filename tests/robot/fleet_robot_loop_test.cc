// The robot loop (`waymark robot --server A,B`) on a fleet of two servers sharing a PostgreSQL
// database (issue 19): when the server serving its session is killed, the robot is stopped and
// stays stopped, and once another server takes the session over (its lease expired) the loop
// resumes the same session there and drives on.

#include <gtest/gtest.h>

#include <atomic>
#include <csignal>
#include <memory>
#include <string>
#include <thread>

#include "client/devices/lms200_scanner.h"
#include "client/devices/pioneer_base.h"
#include "client/lib/channel.h"
#include "client/robot/robot_loop.h"
#include "storage/postgres/pg_admin.h"
#include "tests/robot/eventually.h"
#include "tests/robot/fake_arcos_peer.h"
#include "tests/robot/fake_lms200_peer.h"
#include "tests/storage/store_backend.h"
#include "tests/support/server_process.h"
#include "tests/support/synthetic_scene.h"

namespace waymark::cli {
namespace {

using storage::testing::Backend;
using storage::testing::TestDatabase;
using testing::FakeArcosPeer;
using testing::FakeLms200Options;
using testing::FakeLms200Peer;
using testing::PtyPair;
using testing::Eventually;
using testing::ServerProcess;

TEST(FleetRobotLoopTest, ARobotWhoseServerDiesStopsAndDrivesOnWithAnotherServer) {
  TestDatabase database(Backend::kPostgres);
  WAYMARK_SKIP_WITHOUT(database);
  std::unique_ptr<ServerProcess> servers[2];
  for (auto& server : servers) {
    auto started = ServerProcess::Start(testing::ServerBinary(), database.db(),
                                        {"--session-lease-seconds", "2", "--slam-checkpoint-scans", "2"});
    ASSERT_TRUE(started.ok()) << started.status();
    server = *std::move(started);
  }
  auto pty = PtyPair::Open();
  ASSERT_TRUE(pty.ok()) << pty.status();
  FakeArcosPeer robot(*std::move(pty));
  FakeLms200Options laser_options;
  laser_options.scan_period = absl::Milliseconds(100);
  laser_options.range_mm = testing::RoomRangeMm;
  auto laser = FakeLms200Peer::Start(laser_options);
  ASSERT_TRUE(laser.ok()) << laser.status();
  auto base = adapters::PioneerBase::Connect(robot.device_path());
  ASSERT_TRUE(base.ok()) << base.status();
  auto scanner = adapters::Lms200Scanner::Connect((*laser)->device_path());
  ASSERT_TRUE(scanner.ok()) << scanner.status();
  // What `waymark --server A,B robot` builds (CommandContext::ConnectSlam).
  client::SlamClientOptions client_options;
  client_options.connect = [](const std::string& address) {
    return std::shared_ptr<grpc::ChannelInterface>(client::MakeChannel(address));
  };
  client::SlamClient client(
      client::MakeChannel(servers[0]->address() + "," + servers[1]->address()), client_options);

  RobotLoopOptions options;
  options.robot_id = "pioneer";
  options.mode = DriveMode::kActive;
  options.reconnect_initial = absl::Milliseconds(100);
  options.reconnect_max = absl::Milliseconds(500);
  RobotLoop loop(client, **base, **scanner, options);
  std::atomic<bool> stop{false};
  absl::StatusOr<RobotStatus> result;
  std::thread runner([&] { result = loop.Run(stop); });

  // Driving a suggestion, with the session checkpointed (every 2 scans).
  ASSERT_TRUE(Eventually([&] { return robot.ever_moved() && loop.status().scans_answered >= 5; },
                         absl::Seconds(120)))
      << "moved " << robot.ever_moved() << ", answered " << loop.status().scans_answered
      << ", session " << loop.status().session_id << "\nA:\n"
      << servers[0]->Log() << "\nB:\n"
      << servers[1]->Log();
  const std::string session = loop.status().session_id;
  // The server holding the session, as its lease says.
  absl::StatusOr<std::string> holder = storage::pg::QueryText(
      database.db(), "SELECT lease_address FROM slam_session WHERE id = '" + session + "'");
  ASSERT_TRUE(holder.ok()) << holder.status();
  const int dead = servers[0]->address() == *holder ? 0 : 1;
  ASSERT_EQ(servers[dead]->address(), *holder);
  const uint64_t answered_before = loop.status().scans_answered;
  servers[dead]->Stop(SIGKILL);

  // Stopped while nobody serves the session...
  EXPECT_TRUE(Eventually([&] {
    return robot.last_velocities() == std::make_pair(0, 0) &&
           loop.status().stops[static_cast<int>(StopReason::kStreamBroken)] > 0;
  }));
  // ...then the other server takes it over and the robot goes on with the same session.
  EXPECT_TRUE(Eventually([&] { return loop.status().scans_answered >= answered_before + 2; },
                         absl::Seconds(60)))
      << servers[1 - dead]->Log();
  // Served by the survivor now (the lease says so until the loop closes the session).
  absl::StatusOr<std::string> now = storage::pg::QueryText(
      database.db(), "SELECT lease_address FROM slam_session WHERE id = '" + session + "'");
  ASSERT_TRUE(now.ok()) << now.status();
  EXPECT_EQ(*now, servers[1 - dead]->address());
  stop = true;
  runner.join();
  ASSERT_TRUE(result.ok()) << result.status();
  EXPECT_EQ(result->session_id, session);
  EXPECT_GE(result->reconnects, 1u);
}

}  // namespace
}  // namespace waymark::cli
