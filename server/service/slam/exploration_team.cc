#include "server/service/slam/exploration_team.h"

#include <optional>
#include <utility>

#include "server/laser_slam/geometry.h"

namespace waymark::service {

namespace ls = laser_slam;

namespace {

ls::Pose2 ToPose(const storage::MapTie& tie) { return ls::Pose2{tie.x, tie.y, tie.theta}; }

}  // namespace

void ExplorationTeam::Publish(const std::string& session_id,
                              std::shared_ptr<const ls::ExplorationSnapshot> snapshot) {
  if (snapshot == nullptr) return;
  std::lock_guard<std::mutex> lock(mutex_);
  snapshots_[session_id] = std::move(snapshot);
}

std::vector<ls::Teammate> ExplorationTeam::Teammates(const std::string& session_id) const {
  const std::string map = maps_.MapOf(session_id);
  if (map.empty()) return {};
  const std::vector<std::pair<std::string, storage::MapTie>> members = maps_.TiedMembers(map);
  std::optional<ls::Pose2> own;
  for (const auto& [id, tie] : members) {
    if (id == session_id) own = ToPose(tie);
  }
  if (!own) return {};
  const ls::Pose2 from_map = ls::Invert(*own);
  std::vector<ls::Teammate> out;
  std::lock_guard<std::mutex> lock(mutex_);
  for (const auto& [id, tie] : members) {
    if (id == session_id) continue;
    auto it = snapshots_.find(id);
    if (it == snapshots_.end()) continue;
    // Its planner frame -> its session frame -> the map frame -> this session's frame.
    out.push_back(ls::Teammate{
        it->second,
        ls::Compose(from_map, ls::Compose(ToPose(tie), it->second->local_to_session))});
  }
  return out;
}

void ExplorationTeam::Forget(const std::string& session_id) {
  std::lock_guard<std::mutex> lock(mutex_);
  snapshots_.erase(session_id);
}

}  // namespace waymark::service
