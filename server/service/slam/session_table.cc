#include "server/service/slam/session_table.h"

#include <utility>

namespace waymark::service {

absl::StatusOr<std::shared_ptr<SlamSession>> SessionTable::Find(const std::string& id) const {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = sessions_.find(id);
  if (it == sessions_.end()) return SessionNotFound(id);
  return it->second;
}

void SessionTable::Put(std::shared_ptr<SlamSession> session) {
  std::shared_ptr<SlamSession> replaced;  // destroyed after the lock (see Erase)
  std::lock_guard<std::mutex> lock(mutex_);
  const std::string id = session->id;
  replaced = std::exchange(sessions_[id], std::move(session));
}

void SessionTable::Erase(const std::string& id) {
  // When the table held the last reference, the session and its engine are destroyed here, and
  // that takes time (a long session's nodes and grids) and tells the session's observers
  // (session_memory.h): not under the lock every Find takes.
  std::shared_ptr<SlamSession> erased = Take(id);
}

std::shared_ptr<SlamSession> SessionTable::Take(const std::string& id) {
  std::lock_guard<std::mutex> lock(mutex_);
  auto it = sessions_.find(id);
  if (it == sessions_.end()) return nullptr;
  std::shared_ptr<SlamSession> session = std::move(it->second);
  sessions_.erase(it);
  return session;
}

std::vector<std::shared_ptr<SlamSession>> SessionTable::All() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<std::shared_ptr<SlamSession>> sessions;
  for (const auto& [id, session] : sessions_) sessions.push_back(session);
  return sessions;
}

std::vector<std::string> SessionTable::Ids() const {
  std::lock_guard<std::mutex> lock(mutex_);
  std::vector<std::string> ids;
  for (const auto& [id, session] : sessions_) ids.push_back(id);
  return ids;
}

size_t SessionTable::size() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return sessions_.size();
}

}  // namespace waymark::service
