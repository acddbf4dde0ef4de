// `--server` naming several servers of a fleet (issue 19, client/lib/fleet_target.h): the list
// becomes one round-robin channel over resolved addresses; precise errors for what cannot work.

#include <gtest/gtest.h>

#include "client/cli/server_address.h"
#include "client/lib/fleet_target.h"

namespace waymark::client {
namespace {

TEST(FleetTargetTest, AListBecomesOneRoundRobinTargetOfResolvedAddresses) {
  absl::StatusOr<FleetTarget> fleet = ParseFleetTarget("127.0.0.1:7001, localhost:7002");
  ASSERT_TRUE(fleet.ok()) << fleet.status();
  EXPECT_TRUE(fleet->round_robin);
  EXPECT_EQ(fleet->target, "ipv4:127.0.0.1:7001,127.0.0.1:7002");
  EXPECT_EQ(fleet->authority_host, "127.0.0.1");
  fleet = ParseFleetTarget("127.0.0.1:7001,127.0.0.1:7002,127.0.0.1:7003", 4);  // from the 2nd
  ASSERT_TRUE(fleet.ok()) << fleet.status();
  EXPECT_EQ(fleet->target, "ipv4:127.0.0.1:7002,127.0.0.1:7003,127.0.0.1:7001");
  fleet = ParseFleetTarget("[::1]:7001,[::1]:7002");
  ASSERT_TRUE(fleet.ok()) << fleet.status();
  EXPECT_EQ(fleet->target, "ipv6:[::1]:7001,[::1]:7002");
}

TEST(FleetTargetTest, OneServerIsLeftAsItIsAndDnsAndIpListsSpreadToo) {
  absl::StatusOr<FleetTarget> one = ParseFleetTarget("robot-hub.lab:50051");
  ASSERT_TRUE(one.ok());
  EXPECT_EQ(one->target, "robot-hub.lab:50051");  // not even resolved: gRPC does it, lazily
  EXPECT_FALSE(one->round_robin);
  absl::StatusOr<FleetTarget> dns = ParseFleetTarget("dns:///fleet.lab:50051");
  ASSERT_TRUE(dns.ok());
  EXPECT_TRUE(dns->round_robin);
  absl::StatusOr<FleetTarget> list = ParseFleetTarget("ipv4:10.0.0.1:1,10.0.0.2:2");
  ASSERT_TRUE(list.ok());
  EXPECT_EQ(list->target, "ipv4:10.0.0.1:1,10.0.0.2:2");
  EXPECT_TRUE(list->round_robin);
}

TEST(FleetTargetTest, WhatCannotWorkIsSaidPrecisely) {
  EXPECT_EQ(ParseFleetTarget("127.0.0.1:1,127.0.0.2").status().code(),
            absl::StatusCode::kInvalidArgument);  // no port
  EXPECT_EQ(ParseFleetTarget("127.0.0.1:1,[::1]:2").status().code(),
            absl::StatusCode::kInvalidArgument);  // IPv4 and IPv6 mixed
  absl::Status unknown = ParseFleetTarget("127.0.0.1:1,no-such-host.invalid:2").status();
  EXPECT_EQ(unknown.code(), absl::StatusCode::kNotFound);
  EXPECT_NE(unknown.message().find("no-such-host.invalid"), absl::string_view::npos) << unknown;
}

TEST(FleetTargetTest, TheCommandLineCompletesEveryServerOfAListWithTheDefaultPort) {
  absl::StatusOr<std::string> completed = cli::WithDefaultPort("10.0.0.1,10.0.0.2:7");
  ASSERT_TRUE(completed.ok()) << completed.status();
  EXPECT_EQ(*completed, "10.0.0.1:50051,10.0.0.2:7");
}

}  // namespace
}  // namespace waymark::client
