#ifndef WAYMARK_CLIENT_CLI_SERVER_ADDRESS_H_
#define WAYMARK_CLIENT_CLI_SERVER_ADDRESS_H_

// What a command can tell about a --server address without connecting: whether it is this machine
// (loopback), and its TCP port.

#include <optional>
#include <string>

namespace waymark::cli {

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
