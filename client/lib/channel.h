#ifndef WAYMARK_CLIENT_LIB_CHANNEL_H_
#define WAYMARK_CLIENT_LIB_CHANNEL_H_

#include <grpcpp/channel.h>
#include <grpcpp/security/credentials.h>

#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "absl/time/time.h"

namespace waymark::client {

// Channel settings for robots on Wi-Fi: links drop silently and come back, so the client pings the
// server even when idle, notices a dead link within keepalive_time + keepalive_timeout, and retries
// connecting quickly once the robot is back in range.
//
// The keepalive must agree with the server's ping policy (server/service/runtime/server_channel.h; a test
// checks it): keepalive_time not below the server's minimum ping interval, or the server answers
// GOAWAY "too_many_pings". keepalive_timeout is generous: on a busy machine (a loaded 2-core robot
// computer, a server decoding camera frames on every core) a ping's answer can take seconds, and
// 10 s cut healthy streams with "keepalive watchdog timeout" (issue 15). A dead server is noticed
// sooner by the streams' answer timeouts, and streams resume on a new connection.
struct ChannelOptions {
  absl::Duration keepalive_time = absl::Seconds(30);
  absl::Duration keepalive_timeout = absl::Seconds(20);
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
  // nullptr means plaintext (grpc::InsecureChannelCredentials()); TLS: MakeTlsCredentials().
  std::shared_ptr<grpc::ChannelCredentials> credentials;
  // The name the server's TLS certificate must carry when it differs from the address's host
  // (e.g. connecting by IP to a certificate issued for "waymark.lab"). Empty = the host.
  std::string tls_server_name;
  // Sent as "authorization: Bearer <token>" on every call (what the server's auth checks); empty
  // sends none. Added by a client interceptor rather than call credentials, which gRPC refuses
  // to send over plaintext (the loopback development setup).
  std::string bearer_token;
};

// PEM files for a TLS channel: `ca` verifies the server (empty = the system's roots); `cert` and
// `key` are the client's own certificate for servers that require one (both or neither).
struct TlsFiles {
  std::string ca;
  std::string cert;
  std::string key;
};

// TLS channel credentials from PEM files; NOT_FOUND / INVALID_ARGUMENT naming an unreadable or
// non-PEM file, or a certificate without its key.
absl::StatusOr<std::shared_ptr<grpc::ChannelCredentials>> MakeTlsCredentials(const TlsFiles& files);

// Creates a channel to `address` ("host:port", or any gRPC target URI, or several comma-separated
// "host:port" spread over with round_robin: fleet_target.h). Connection happens lazily on the
// first call, so this never fails; connection errors surface as UNAVAILABLE from calls.
std::shared_ptr<grpc::Channel> MakeChannel(const std::string& address,
                                           const ChannelOptions& options = {});

}  // namespace waymark::client

#endif  // WAYMARK_CLIENT_LIB_CHANNEL_H_
