#include "storage/postgres/pg_coordination.h"

#include <poll.h>

#include <chrono>
#include <utility>

#include "absl/strings/str_cat.h"
#include "storage/status_macros.h"

namespace waymark::storage::pg {
namespace {

constexpr char kLockTimeout[] = "30s";

class AdvisoryLock final : public DatabaseWriteLock {
 public:
  AdvisoryLock(Pool::Lease lease, int64_t key) : lease_(std::move(lease)), key_(key) {}
  ~AdvisoryLock() override {
    // A failure means the connection is gone, and the lock with it.
    lease_.connection()
        .Execute("SELECT pg_advisory_unlock($1)::int", Params().Int64(key_))
        .status()
        .IgnoreError();
  }

 private:
  Pool::Lease lease_;
  int64_t key_;
};

class NotificationFeed final : public ChangeFeed {
 public:
  explicit NotificationFeed(std::unique_ptr<Connection> connection)
      : connection_(std::move(connection)) {}

  absl::StatusOr<bool> Wait(int timeout_ms) override {
    PGconn* conn = connection_->raw();
    bool any = Drain();
    if (!any) {
      pollfd fd{PQsocket(conn), POLLIN, 0};
      if (fd.fd < 0) return Lost();
      const int ready = poll(&fd, 1, timeout_ms);
      if (ready < 0 && errno != EINTR) return Lost();
      any = Drain();
    }
    if (PQstatus(conn) != CONNECTION_OK) return Lost();
    return any;
  }

 private:
  // Reads what the socket holds and consumes every notification; true when there was one.
  bool Drain() {
    PGconn* conn = connection_->raw();
    if (PQconsumeInput(conn) == 0) return false;
    bool any = false;
    while (PGnotify* notify = PQnotifies(conn)) {
      any = true;
      PQfreemem(notify);
    }
    return any;
  }

  absl::Status Lost() {
    return absl::UnavailableError("the connection that listens for other servers' changes is lost");
  }

  std::unique_ptr<Connection> connection_;
};

}  // namespace

absl::StatusOr<std::unique_ptr<DatabaseWriteLock>> HoldAdvisoryLock(Pool& pool, int64_t key,
                                                                    const std::string& what) {
  ASSIGN_OR_RETURN(Pool::Lease lease, pool.Hold());
  Connection& connection = lease.connection();
  RETURN_IF_ERROR(connection.Script(absl::StrCat("SET lock_timeout = '", kLockTimeout, "'")));
  absl::Status locked =
      connection.Execute("SELECT pg_advisory_lock($1)", Params().Int64(key)).status();
  const absl::Status reset = connection.Script("SET lock_timeout = 0");
  if (!locked.ok()) {
    // lock_timeout passed (55P03, UNAVAILABLE with the connection still up): say what it means.
    if (absl::IsUnavailable(locked) && connection.healthy()) {
      return absl::UnavailableError(absl::StrCat(
          what, " stayed locked by another server's write for ", kLockTimeout, "; try again"));
    }
    return locked;
  }
  RETURN_IF_ERROR(reset);
  return std::unique_ptr<DatabaseWriteLock>(new AdvisoryLock(std::move(lease), key));
}

absl::StatusOr<std::unique_ptr<ChangeFeed>> Listen(const std::string& uri,
                                                   const std::string& channel) {
  ASSIGN_OR_RETURN(std::unique_ptr<Connection> connection, Connection::Open(uri));
  RETURN_IF_ERROR(connection->Script(absl::StrCat("LISTEN ", channel)));
  return std::unique_ptr<ChangeFeed>(new NotificationFeed(std::move(connection)));
}

}  // namespace waymark::storage::pg
