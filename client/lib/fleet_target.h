#ifndef WAYMARK_CLIENT_LIB_FLEET_TARGET_H_
#define WAYMARK_CLIENT_LIB_FLEET_TARGET_H_

// `--server` naming several servers (issue 19, docs/scale-out.md): "a:50051,b:50051,10.0.0.3:50051"
// becomes one gRPC channel that spreads calls over all of them with gRPC's own `round_robin`
// policy and skips the ones that are down. A single "dns:///name:port" with several records, and
// gRPC's own "ipv4:a:p,b:p" lists, get the same policy; a single address is left as it is.

#include <string>
#include <vector>

#include "absl/status/statusor.h"

namespace waymark::client {

struct FleetTarget {
  std::string target;          // what grpc::CreateChannel takes
  bool round_robin = false;    // set the round_robin load-balancing policy
  std::string authority_host;  // the first server's host name, for TLS name checks ("" = none)
};

// Resolves each host of a comma-separated list once, now (getaddrinfo), into an ipv4:/ipv6:
// target of addresses. INVALID_ARGUMENT for an entry without a port, or a list that mixes IPv4 and
// IPv6 servers; NOT_FOUND when a host does not resolve (naming it). The list is rotated to start
// at entry `first` (modulo its length): gRPC's round_robin starts at the first address, so robots
// that all name "A,B,C" would all begin on A; MakeChannel rotates by a random amount.
absl::StatusOr<FleetTarget> ParseFleetTarget(const std::string& address, size_t first = 0);

}  // namespace waymark::client

#endif  // WAYMARK_CLIENT_LIB_FLEET_TARGET_H_
