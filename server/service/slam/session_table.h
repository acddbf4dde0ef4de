#ifndef WAYMARK_SERVER_SERVICE_SLAM_SESSION_TABLE_H_
#define WAYMARK_SERVER_SERVICE_SLAM_SESSION_TABLE_H_

// The sessions resident on this server (open and in memory), by id. Guards the table, not the
// sessions: callers lock a session's own mutexes after the table's lock is released.

#include <cstddef>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "absl/status/statusor.h"
#include "server/service/slam/folder.h"
#include "server/service/slam/slam_session.h"

namespace waymark::service {

class SessionTable {
 public:
  // NOT_FOUND (SessionNotFound) when the session is not resident.
  absl::StatusOr<std::shared_ptr<SlamSession>> Find(const std::string& id) const;
  // Makes `session` resident under its id (replacing one of the same id).
  void Put(std::shared_ptr<SlamSession> session);
  void Erase(const std::string& id);
  // Removes the session and returns it; null when it was not resident.
  std::shared_ptr<SlamSession> Take(const std::string& id);
  // The resident sessions (ids) at the time of the call, in id order.
  std::vector<std::shared_ptr<SlamSession>> All() const;
  std::vector<std::string> Ids() const;
  size_t size() const;

 private:
  mutable std::mutex mutex_;  // guards sessions_
  std::map<std::string, std::shared_ptr<SlamSession>> sessions_;
};

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_SLAM_SESSION_TABLE_H_
