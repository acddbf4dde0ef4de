#ifndef WAYMARK_SERVER_SERVICE_SLAM_SESSION_LEASES_H_
#define WAYMARK_SERVER_SERVICE_SLAM_SESSION_LEASES_H_

// This server's leases on SLAM sessions (issue 19, storage::SlamLease): when several servers
// share one database, a session is served by the one server that holds its lease. The registry
// takes the lease before a session becomes resident, renews the leases of its resident sessions
// every ttl/3, fences every checkpoint with it, and gives them up at shutdown. A session whose
// lease another server holds is refused with FAILED_PRECONDITION carrying that server's address
// (SessionOwnerAddress), so a client can go there; once the holder dies and its lease expires,
// any server takes the session over from its last checkpoint.

#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "server/service/slam/folder.h"
#include "storage/slam_store.h"

namespace waymark::service {

struct SessionLeaseOptions {
  // This server's id in the leases; empty = no leases (one server per database: SQLite).
  std::string owner;
  // Where robots reach this server (host:port), named in the redirects other servers give.
  std::string address;
  // How long a lease lasts unrenewed: the longest a dead server's sessions wait for another
  // server. Renewed every third of it, so a lease survives two missed renewals.
  double ttl_seconds = 15;
};

// The type URL of the payload that carries the holder's address in a redirect status.
inline constexpr char kSessionOwnerPayload[] = "type.waymark.dev/session-owner";
// The gRPC trailing metadata key the service puts the same address in (crossing the wire).
inline constexpr char kSessionOwnerMetadata[] = "waymark-session-owner";

// The address of the server holding the session, when `status` is such a redirect.
std::optional<std::string> SessionOwnerAddress(const absl::Status& status);

class SessionLeases {
 public:
  SessionLeases(storage::SlamStore* store, SessionLeaseOptions options)
      : store_(store), options_(std::move(options)), address_(options_.address) {}

  bool enabled() const { return !options_.owner.empty(); }
  // Where robots reach this server, once known (a server listening on port 0 learns its port
  // only when it starts serving).
  void set_address(const std::string& address) {
    std::lock_guard<std::mutex> lock(mutex_);
    address_ = address;
  }
  std::string address() {
    std::lock_guard<std::mutex> lock(mutex_);
    return address_;
  }
  // The owner to fence checkpoints with ("" when leases are off).
  const std::string& owner() const { return options_.owner; }
  double ttl_seconds() const { return options_.ttl_seconds; }

  // OK when this server now holds the session's lease (taken or renewed; always OK when leases
  // are off); FAILED_PRECONDITION with the holder's address (SessionOwnerAddress) when another
  // server holds an unexpired one; the store's error otherwise.
  absl::Status Take(const std::string& session_id);
  // Renews the leases of `session_ids`; returns those another server has taken over meanwhile
  // (this one stopped renewing long enough, e.g. cut off from the database), each with an
  // UNAVAILABLE status for its stream that names the new holder (SessionOwnerAddress). A session
  // whose renewal failed for another reason (the database unreachable) is kept: nobody can take
  // it while nobody can reach the database, and checkpoints are fenced anyway.
  std::vector<std::pair<std::string, absl::Status>> Renew(
      const std::vector<std::string>& session_ids);
  // Gives the lease up (a clean shutdown: another server need not wait for it to expire).
  void Release(const std::string& session_id);

 private:
  storage::SlamStore* store_;
  const SessionLeaseOptions options_;
  std::mutex mutex_;
  std::string address_;  // guarded by mutex_
};

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_SLAM_SESSION_LEASES_H_
