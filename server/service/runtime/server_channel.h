#ifndef WAYMARK_SERVER_SERVICE_RUNTIME_SERVER_CHANNEL_H_
#define WAYMARK_SERVER_SERVICE_RUNTIME_SERVER_CHANNEL_H_

// The server's HTTP/2 connection settings: keepalive, the ping policy clients must keep to,
// message sizes and request threads.
//
// Keepalive has two sides that must agree (tests/service/keepalive_test.cc checks them against
// the client library's defaults, client/lib/channel.h): a client that pings more often than the
// server permits is sent GOAWAY "too_many_pings", and a peer whose ping timeout is shorter than
// the delay of a busy machine (a 2-core robot computer under load, or a server decoding camera
// frames on every core) cuts healthy connections with "keepalive watchdog timeout" (issue 15:
// `vo run` died after 50 of 140 frames). The timeouts are generous: a dead link is also noticed by
// the robots' own answer timeouts, and their streams resume on a new connection.

#include <grpcpp/server_builder.h>

#include "absl/time/time.h"
#include "server/service/runtime/folder.h"

namespace waymark::service {

// The server pings a connection quiet for this long, and drops it when the ping is not answered
// within the timeout: a robot that vanished without closing its connection.
inline constexpr absl::Duration kServerKeepaliveTime = absl::Seconds(60);
inline constexpr absl::Duration kServerKeepaliveTimeout = absl::Seconds(20);
// Clients may ping this often without sending data (and while they have no call open); pings more
// often than that are counted, but never end the connection (no ping strikes: an abusive client
// is a matter for authentication and the stream limits, not for pings).
inline constexpr absl::Duration kMinClientPingInterval = absl::Seconds(10);

struct ServerChannelOptions {
  int max_message_mb = 32;
  int threads = 0;  // 0: gRPC's default (grows with load)
};

// Applies keepalive, the ping policy, message sizes and the thread limit to `builder`.
void ConfigureServerChannel(grpc::ServerBuilder* builder, const ServerChannelOptions& options);

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_RUNTIME_SERVER_CHANNEL_H_
