#include "client/lib/fleet_target.h"

#include <arpa/inet.h>
#include <netdb.h>
#include <sys/socket.h>

#include <algorithm>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"

namespace waymark::client {
namespace {

struct Resolved {
  std::string ip;  // numeric
  bool v6 = false;
};

absl::StatusOr<Resolved> Resolve(const std::string& host) {
  addrinfo hints{};
  hints.ai_family = AF_UNSPEC;
  hints.ai_socktype = SOCK_STREAM;
  addrinfo* found = nullptr;
  if (const int rc = getaddrinfo(host.c_str(), nullptr, &hints, &found); rc != 0 || !found) {
    return absl::NotFoundError(
        absl::StrCat("server host \"", host, "\" does not resolve: ", gai_strerror(rc)));
  }
  Resolved out;
  char text[INET6_ADDRSTRLEN] = {};
  // The first IPv4 address if there is one (the usual case), else the first IPv6 one.
  const addrinfo* pick = found;
  for (const addrinfo* a = found; a != nullptr; a = a->ai_next) {
    if (a->ai_family == AF_INET) {
      pick = a;
      break;
    }
  }
  if (pick->ai_family == AF_INET) {
    inet_ntop(AF_INET, &reinterpret_cast<const sockaddr_in*>(pick->ai_addr)->sin_addr, text,
              sizeof(text));
  } else {
    inet_ntop(AF_INET6, &reinterpret_cast<const sockaddr_in6*>(pick->ai_addr)->sin6_addr, text,
              sizeof(text));
    out.v6 = true;
  }
  freeaddrinfo(found);
  out.ip = text;
  return out;
}

}  // namespace

absl::StatusOr<FleetTarget> ParseFleetTarget(const std::string& address, size_t first) {
  FleetTarget fleet;
  if (absl::StartsWith(address, "ipv4:") || absl::StartsWith(address, "ipv6:")) {
    // gRPC's own address lists: spread over them too.
    fleet.target = address;
    fleet.round_robin = absl::StrContains(address, ',');
    return fleet;
  }
  std::vector<std::string> entries;
  for (absl::string_view e : absl::StrSplit(address, ',', absl::SkipWhitespace())) {
    entries.emplace_back(absl::StripAsciiWhitespace(e));
  }
  if (entries.size() <= 1) {
    fleet.target = entries.empty() ? address : entries[0];
    // A DNS name may stand for several servers: spread over all its records.
    fleet.round_robin = absl::StartsWith(fleet.target, "dns:");
    return fleet;
  }
  std::vector<std::string> resolved;
  int v6 = 0;
  for (const std::string& entry : entries) {
    std::string host, port;
    if (absl::StartsWith(entry, "[")) {  // [ipv6]:port
      const size_t close = entry.find("]:");
      if (close == std::string::npos) {
        return absl::InvalidArgumentError(absl::StrCat("server \"", entry, "\" has no port"));
      }
      host = entry.substr(1, close - 1);
      port = entry.substr(close + 2);
    } else {
      const size_t colon = entry.rfind(':');
      if (colon == std::string::npos || colon + 1 == entry.size()) {
        return absl::InvalidArgumentError(absl::StrCat(
            "server \"", entry, "\" has no port: with several servers give each HOST:PORT"));
      }
      host = entry.substr(0, colon);
      port = entry.substr(colon + 1);
    }
    absl::StatusOr<Resolved> ip = Resolve(host);
    if (!ip.ok()) return ip.status();
    if (fleet.authority_host.empty()) fleet.authority_host = host;
    v6 += ip->v6 ? 1 : 0;
    resolved.push_back(ip->v6 ? absl::StrCat("[", ip->ip, "]:", port)
                              : absl::StrCat(ip->ip, ":", port));
  }
  if (v6 != 0 && v6 != static_cast<int>(resolved.size())) {
    return absl::InvalidArgumentError(
        absl::StrCat("the servers \"", address, "\" mix IPv4 and IPv6 addresses; give one kind"));
  }
  std::rotate(resolved.begin(), resolved.begin() + first % resolved.size(), resolved.end());
  fleet.target = absl::StrCat(v6 ? "ipv6:" : "ipv4:", absl::StrJoin(resolved, ","));
  fleet.round_robin = true;
  return fleet;
}

}  // namespace waymark::client
