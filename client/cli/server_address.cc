#include "client/cli/server_address.h"

#include <arpa/inet.h>

#include "absl/strings/ascii.h"
#include "absl/strings/match.h"
#include "absl/strings/numbers.h"
#include "absl/strings/string_view.h"
#include "absl/strings/strip.h"

namespace waymark::cli {

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
