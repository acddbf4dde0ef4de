#ifndef WAYMARK_SERVER_SERVICE_SLAM_SESSION_LIFECYCLE_H_
#define WAYMARK_SERVER_SERVICE_SLAM_SESSION_LIFECYCLE_H_

// The life of a SLAM session on this server: created (or imported as a closed map), made resident
// (taking its lease, loading it from the store), closed, deleted, and dropped when another server
// took its lease over. Loading, creating and closing are serialized (not the hot path).

#include <atomic>
#include <memory>
#include <mutex>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "server/service/slam/folder.h"
#include "server/service/slam/session_engine.h"
#include "server/service/slam/session_leases.h"
#include "server/service/slam/slam_registry_options.h"
#include "server/service/slam/slam_session.h"
#include "storage/slam_store.h"
#include "waymark/v1/slam.pb.h"

namespace waymark::service {

class SessionPersistence;
class SessionTable;

class SessionLifecycle {
 public:
  // None is owned; all must outlive this.
  SessionLifecycle(storage::SlamStore* store, const SlamRegistryOptions& options,
                   const std::atomic<bool>* shutting_down, SessionLeases* leases,
                   SessionTable* table, SessionPersistence* persistence)
      : store_(store), options_(options), shutting_down_(shutting_down), leases_(leases),
        table_(table), persistence_(persistence) {}

  // SlamRegistry::CreateSession, ImportMap, CloseSession and DeleteSession (slam_registry.h).
  absl::StatusOr<v1::Session> CreateSession(const v1::CreateSessionRequest& request);
  absl::StatusOr<v1::Session> ImportMap(const v1::ImportMapRequest& request);
  absl::StatusOr<v1::Session> CloseSession(const std::string& session_id);
  absl::StatusOr<v1::DeleteSessionResponse> DeleteSession(const std::string& session_id,
                                                          bool force);
  // The resident session, or the open session loaded from the store and made resident (taking
  // its lease); `loaded` (optional) tells whether this call loaded it.
  absl::StatusOr<std::shared_ptr<SlamSession>> ResidentOrLoad(const std::string& id,
                                                              bool* loaded = nullptr);
  // Renews the leases of the resident sessions; drops those another server took over (see
  // DropLost).
  void RenewLeases();

 private:
  // Checks the request's common fields (robot id, name) as CreateSession does.
  static absl::Status CheckNewSessionRequest(const std::string& robot_id, const std::string& name);
  // Stores a new session around `engine` (id, limits) and makes it resident unless `close`.
  absl::StatusOr<v1::Session> StoreNewSession(const std::string& robot_id,
                                              const std::string& name, std::string config_bytes,
                                              std::unique_ptr<SessionEngine> engine, bool close);
  // CloseSession's work, with load_mutex_ held.
  absl::Status CloseLocked(const std::string& session_id);
  // Removes a session whose lease another server holds: no checkpoint, its stream is told.
  void DropLost(const std::string& session_id, const absl::Status& moved);

  storage::SlamStore* const store_;
  const SlamRegistryOptions& options_;
  const std::atomic<bool>* const shutting_down_;
  SessionLeases* const leases_;
  SessionTable* const table_;
  SessionPersistence* const persistence_;

  std::mutex load_mutex_;  // serializes loading/creating/closing sessions (not the hot path)
};

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_SLAM_SESSION_LIFECYCLE_H_
