// The two sides of keepalive agree (issue 15: `vo run` died with "keepalive watchdog timeout"):
// the client library's default pings keep to the server's ping policy, and neither side cuts a
// connection whose pings are answered late by a busy machine. Checked on the values themselves:
// the failures they prevent only show under load, which a test must not depend on.
#include <gtest/gtest.h>

#include "client/lib/channel.h"
#include "server/service/runtime/server_channel.h"

namespace waymark {
namespace {

TEST(KeepaliveTest, ClientPingsNoMoreOftenThanTheServerPermits) {
  const client::ChannelOptions client;
  // More often would be answered with GOAWAY "too_many_pings" once strikes are counted.
  EXPECT_GE(client.keepalive_time, service::kMinClientPingInterval);
}

TEST(KeepaliveTest, PingTimeoutsSurviveABusyMachine) {
  // A ping answer delayed this long is a busy peer, not a dead one (10 s was not enough).
  const absl::Duration busy_machine = absl::Seconds(20);
  EXPECT_GE(client::ChannelOptions().keepalive_timeout, busy_machine);
  EXPECT_GE(service::kServerKeepaliveTimeout, busy_machine);
}

}  // namespace
}  // namespace waymark
