#ifndef WAYMARK_SERVER_SERVICE_SLAM_TRAJECTORY_FEED_H_
#define WAYMARK_SERVER_SERVICE_SLAM_TRAJECTORY_FEED_H_

// The node feed of a shared map on a fleet (issue 38; docs/laser-slam.md, "On a fleet"): a robot
// streams to one server while another owns its map (ties and follows its robots). Without the
// feed the owner reads the robot's session from its checkpoints, every 30 s or 500 scans by
// default; with it the robot's server publishes the session's nodes as they come
// (storage::MapStore::PublishTrajectoryFeed, by the tie worker's thread, map_tie_worker.h) and
// the owner reads them from the database. A node's points are written once; the poses and loops,
// which every loop closure moves, at each publish (laser_slam/mapping/node_feed_codec.h).

#include <cstdint>
#include <optional>
#include <set>
#include <string>

#include "absl/status/statusor.h"
#include "server/service/slam/trajectory_nodes.h"
#include "storage/map_store.h"

namespace waymark::service {

// What this server published of one session: the next update brings the feed from there to the
// session's nodes now.
class FeedPublisher {
 public:
  // The update; nullopt when nothing changed since the last one published (same poses, loops
  // and nodes). The first of a publisher replaces whatever the feed held (another server may
  // have published the session before).
  std::optional<storage::TrajectoryFeedUpdate> Update(const TrajectoryNodes& nodes) const;
  // `update` (from Update) is in the database.
  void Published(const storage::TrajectoryFeedUpdate& update);
  // Whether it published anything yet.
  bool any() const { return !poses_.empty(); }

 private:
  std::set<std::int64_t> scans_;  // the nodes whose points are in the feed
  std::string poses_;             // the poses last published (never empty once published)
};

// The session's nodes from a feed read (MapStore::ReadTrajectoryFeed) and the nodes held before
// (their points are reused by scan: a node's points never change). DATA_LOSS for bytes that do
// not decode, or a node whose points are in neither.
absl::StatusOr<TrajectoryNodes> JoinFeed(const TrajectoryNodes& held,
                                         const storage::TrajectoryFeed& feed);

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_SLAM_TRAJECTORY_FEED_H_
