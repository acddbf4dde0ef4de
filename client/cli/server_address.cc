#include "client/cli/server_address.h"

#include <arpa/inet.h>

#include <algorithm>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "absl/strings/string_view.h"
#include "absl/strings/strip.h"

namespace waymark::cli {
namespace {

absl::Status BadAddress(const std::string& target, absl::string_view why) {
  return absl::InvalidArgumentError(absl::StrCat(
      "server address '", target, "': ", why,
      "; expected HOST[:PORT], [IPV6][:PORT] or unix:PATH (the port defaults to ",
      kDefaultServerPort, ")"));
}

// One address of a target, its scheme removed: "host", "host:port", "[v6]", "[v6]:port" or a bare
// "v6" (several colons and no brackets: an IPv6 address cannot carry a port without them).
absl::StatusOr<std::string> CompleteAddress(absl::string_view address, const std::string& target) {
  absl::string_view host = address;
  std::optional<absl::string_view> port;
  if (absl::StartsWith(address, "[")) {
    const size_t close = address.find(']');
    if (close == absl::string_view::npos) return BadAddress(target, "'[' without ']'");
    host = address.substr(1, close - 1);
    absl::string_view rest = address.substr(close + 1);
    if (!rest.empty()) {
      if (!absl::ConsumePrefix(&rest, ":")) return BadAddress(target, "expected ':PORT' after ']'");
      port = rest;
    }
  } else {
    const auto colons = std::count(address.begin(), address.end(), ':');
    if (colons > 1) return absl::StrCat("[", address, "]:", kDefaultServerPort);
    if (colons == 1) {
      const size_t colon = address.find(':');
      host = address.substr(0, colon);
      port = address.substr(colon + 1);
    }
  }
  if (host.empty()) return BadAddress(target, "no host");
  if (!port.has_value()) return absl::StrCat(address, ":", kDefaultServerPort);
  int value = 0;
  if (!absl::SimpleAtoi(*port, &value) || value < 1 || value > 65535) {
    return BadAddress(target, absl::StrCat("port '", *port, "' is not a number in 1..65535"));
  }
  return std::string(address);
}

}  // namespace

absl::StatusOr<std::string> WithDefaultPort(const std::string& target) {
  if (target.empty()) return BadAddress(target, "empty");
  absl::string_view rest = target;
  std::string scheme;
  bool address_list = false;
  if (absl::ConsumePrefix(&rest, "dns:")) {
    scheme = "dns:";
    if (absl::StartsWith(rest, "//")) {  // dns://[AUTHORITY]/HOST[:PORT]
      const size_t slash = rest.find('/', 2);
      if (slash == absl::string_view::npos) return BadAddress(target, "no '/' after the authority");
      absl::StrAppend(&scheme, rest.substr(0, slash + 1));
      rest.remove_prefix(slash + 1);
    }
  } else if (absl::StartsWith(rest, "ipv4:") || absl::StartsWith(rest, "ipv6:")) {
    scheme = std::string(rest.substr(0, 5));
    rest.remove_prefix(5);
    address_list = true;
  } else if (absl::StartsWith(rest, "unix:") || absl::StartsWith(rest, "unix-abstract:") ||
             absl::StrContains(rest, ":/")) {
    return target;  // a socket, or a scheme of gRPC's that names no host and port
  } else if (absl::StrContains(rest, ',')) {
    address_list = true;  // several servers, "a:50051,b" (client/lib/fleet_target.h)
  }
  std::vector<std::string> completed;
  for (absl::string_view address :
       address_list ? std::vector<absl::string_view>(absl::StrSplit(rest, ','))
                    : std::vector<absl::string_view>{rest}) {
    absl::StatusOr<std::string> one = CompleteAddress(address, target);
    if (!one.ok()) return one.status();
    completed.push_back(*std::move(one));
  }
  return absl::StrCat(scheme, absl::StrJoin(completed, ","));
}

std::optional<HostPort> ParseHostPort(const std::string& target) {
  absl::string_view rest = target;
  for (absl::string_view scheme : {"dns:///", "dns:", "ipv4:", "ipv6:"}) {
    if (absl::ConsumePrefix(&rest, scheme)) break;
  }
  if (absl::StrContains(rest, ',') || absl::StrContains(rest, '/')) return std::nullopt;
  const size_t colon = rest.rfind(':');
  if (colon == absl::string_view::npos) return std::nullopt;
  HostPort result;
  if (!absl::SimpleAtoi(rest.substr(colon + 1), &result.port) || result.port <= 0 ||
      result.port > 65535) {
    return std::nullopt;
  }
  absl::string_view host = rest.substr(0, colon);
  if (absl::ConsumePrefix(&host, "[")) {
    if (!absl::ConsumeSuffix(&host, "]")) return std::nullopt;
  } else if (absl::StrContains(host, ':')) {
    return std::nullopt;  // an IPv6 address needs brackets before a port
  }
  if (host.empty()) return std::nullopt;
  result.host = std::string(host);
  return result;
}

bool IsLoopbackTarget(const std::string& target) {
  if (absl::StartsWith(target, "unix:")) return true;
  const std::optional<HostPort> parsed = ParseHostPort(target);
  if (!parsed) return false;
  const std::string host = absl::AsciiStrToLower(parsed->host);
  if (host == "localhost" || absl::EndsWith(host, ".localhost")) return true;
  in_addr v4;
  if (inet_pton(AF_INET, host.c_str(), &v4) == 1) return (ntohl(v4.s_addr) >> 24) == 127;
  in6_addr v6;
  return inet_pton(AF_INET6, host.c_str(), &v6) == 1 && IN6_IS_ADDR_LOOPBACK(&v6);
}

}  // namespace waymark::cli
