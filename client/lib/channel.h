#ifndef WAYMARK_CLIENT_LIB_CHANNEL_H_
#define WAYMARK_CLIENT_LIB_CHANNEL_H_

#include <grpcpp/channel.h>
#include <grpcpp/security/credentials.h>

#include <memory>
#include <string>

#include "absl/time/time.h"

namespace waymark::client {

// Channel settings for robots on Wi-Fi: links drop silently and come back, so the client pings the
// server even when idle, notices a dead link within keepalive_time + keepalive_timeout, and retries
// connecting quickly once the robot is back in range.
struct ChannelOptions {
  absl::Duration keepalive_time = absl::Seconds(20);
  absl::Duration keepalive_timeout = absl::Seconds(10);
  // Ping while no call is active, so the first call after a quiet period does not hit a dead link.
  // The server must allow it (see the report in crossing_client.h).
  bool keepalive_permit_without_calls = true;
  // Upper bound on gRPC's reconnect backoff (its default, 120 s, is far too long for a robot that
  // just drove back under an access point).
  absl::Duration max_reconnect_backoff = absl::Seconds(10);
  // First reconnect delay (gRPC's default is 1 s, growing 1.6x with jitter): a restarted server
  // is back within a second, and a robot standing still until then should not wait several.
  absl::Duration initial_reconnect_backoff = absl::Milliseconds(250);
  // Applies to both directions; camera frames and bulk imports stay well under it.
  int max_message_bytes = 64 * 1024 * 1024;
  // nullptr means plaintext (grpc::InsecureChannelCredentials()).
  std::shared_ptr<grpc::ChannelCredentials> credentials;
};

// Creates a channel to `address` ("host:port", or any gRPC target URI). Connection happens lazily
// on the first call, so this never fails; connection errors surface as UNAVAILABLE from calls.
std::shared_ptr<grpc::Channel> MakeChannel(const std::string& address,
                                           const ChannelOptions& options = {});

}  // namespace waymark::client

#endif  // WAYMARK_CLIENT_LIB_CHANNEL_H_
