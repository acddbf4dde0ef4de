#ifndef WAYMARK_SERVER_SERVICE_SLAM_EXPLORATION_TEAM_H_
#define WAYMARK_SERVER_SERVICE_SLAM_EXPLORATION_TEAM_H_

// Several robots exploring one map (issue 38; docs/exploration.md, "Several robots"): the part of
// the SLAM registry that lets the goal layers of a map's robots see each other. Every laser session
// in a map publishes its exploration snapshot after each decision
// (laser_slam/exploration/shared_exploration.h); before each decision it is handed the snapshots of
// the other sessions tied into the same map, each with the transform from that robot's frame into
// its own, through the map's origins (map_registry.h). A robot not yet tied in, or alone in its
// map, gets none and explores as a session in no map does.
//
// Thread-safe: sessions publish and read from their own strands. A snapshot is immutable once
// published and shared by pointer, so a read copies pointers, not grids.

#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "server/laser_slam/exploration/shared_exploration.h"
#include "server/service/slam/folder.h"
#include "server/service/slam/map_registry.h"

namespace waymark::service {

class ExplorationTeam {
 public:
  // `maps` is not owned and must outlive this.
  explicit ExplorationTeam(const MapRegistry& maps) : maps_(maps) {}

  // The session's latest snapshot (null is ignored).
  void Publish(const std::string& session_id,
               std::shared_ptr<const laser_slam::ExplorationSnapshot> snapshot);
  // The other robots tied into the session's map that published a snapshot, each placed in the
  // session's own frame; empty when the session is in no map or not tied in.
  std::vector<laser_slam::Teammate> Teammates(const std::string& session_id) const;
  // The session was deleted: its snapshot goes. (A closed session's stays: what it explored is
  // still explored.)
  void Forget(const std::string& session_id);

 private:
  const MapRegistry& maps_;
  mutable std::mutex mutex_;
  std::map<std::string, std::shared_ptr<const laser_slam::ExplorationSnapshot>> snapshots_;
};

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_SLAM_EXPLORATION_TEAM_H_
