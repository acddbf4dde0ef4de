#ifndef WAYMARK_CLIENT_CLI_SERVER_ADDRESS_H_
#define WAYMARK_CLIENT_CLI_SERVER_ADDRESS_H_

// What a command can tell about a --server address without connecting: whether it is this machine
// (loopback), and its TCP port; and the address completed with the default port, which is what the
// command line dials.

#include <optional>
#include <string>

#include "absl/status/statusor.h"

namespace waymark::cli {

// The port `waymark-server` listens on by default, and so the one a --server without a port means.
inline constexpr int kDefaultServerPort = 50051;

// `target` with kDefaultServerPort added where it names a host without a port: "10.0.0.7" ->
// "10.0.0.7:50051", "[::1]" and "::1" -> "[::1]:50051", "dns:///robot-hub" ->
// "dns:///robot-hub:50051" (also after the ipv4: and ipv6: schemes, and in a plain comma-separated
// list of several servers, "a,b:6000" -> "a:50051,b:6000": to every address of a list).
// A target with a port, a unix socket ("unix:PATH", "unix-abstract:NAME") or another scheme is
// returned as is. INVALID_ARGUMENT for an empty target, an empty host, or a port that is not in
// 1..65535 (gRPC would dial port 0, or fail with an unhelpful message).
absl::StatusOr<std::string> WithDefaultPort(const std::string& target);

// The host and port of a gRPC target: "host:port", "[v6]:port", "ipv4:host:port",
// "ipv6:[v6]:port", "dns:host:port", "dns:///host:port". nullopt for anything else (unix sockets,
// a target without a port, several addresses).
struct HostPort {
  std::string host;  // without brackets
  int port = 0;
};
std::optional<HostPort> ParseHostPort(const std::string& target);

// A server on this machine: localhost, 127.0.0.0/8, ::1, or a unix socket ("unix:PATH").
bool IsLoopbackTarget(const std::string& target);

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_CLI_SERVER_ADDRESS_H_
