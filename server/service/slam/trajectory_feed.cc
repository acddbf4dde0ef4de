#include "server/service/slam/trajectory_feed.h"

#include <map>
#include <memory>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/strings/str_cat.h"
#include "server/laser_slam/mapping/node_feed_codec.h"

namespace waymark::service {

std::optional<storage::TrajectoryFeedUpdate> FeedPublisher::Update(
    const TrajectoryNodes& nodes) const {
  storage::TrajectoryFeedUpdate update;
  update.scans_processed = nodes.scans_processed;
  update.poses = laser_slam::EncodeFeedPoses(nodes.nodes, nodes.loops);
  update.replace = !any();
  std::set<std::int64_t> now;
  for (const laser_slam::NodeView& node : nodes.nodes) {
    const auto scan = static_cast<std::int64_t>(node.scan);
    now.insert(scan);
    if ((update.replace || scans_.count(scan) == 0) && node.points != nullptr) {
      update.added.push_back(
          storage::FeedNodePoints{scan, laser_slam::EncodeFeedPoints(*node.points)});
    }
  }
  if (!update.replace) {
    for (const std::int64_t scan : scans_) {
      if (now.count(scan) == 0) update.dropped.push_back(scan);
    }
    if (update.added.empty() && update.dropped.empty() && update.poses == poses_) {
      return std::nullopt;
    }
  }
  return update;
}

void FeedPublisher::Published(const storage::TrajectoryFeedUpdate& update) {
  if (update.replace) scans_.clear();
  for (const std::int64_t scan : update.dropped) scans_.erase(scan);
  for (const storage::FeedNodePoints& node : update.added) scans_.insert(node.scan);
  poses_ = update.poses;
}

absl::StatusOr<TrajectoryNodes> JoinFeed(const TrajectoryNodes& held,
                                         const storage::TrajectoryFeed& feed) {
  absl::StatusOr<laser_slam::FeedPoses> poses = laser_slam::DecodeFeedPoses(feed.poses);
  if (!poses.ok()) return poses.status();
  std::map<std::uint64_t, std::shared_ptr<const laser_slam::PointCloud>> points;
  for (const laser_slam::NodeView& node : held.nodes) points[node.scan] = node.points;
  for (const storage::FeedNodePoints& node : feed.points) {
    absl::StatusOr<laser_slam::PointCloud> cloud = laser_slam::DecodeFeedPoints(node.points);
    if (!cloud.ok()) return cloud.status();
    points[static_cast<std::uint64_t>(node.scan)] =
        std::make_shared<const laser_slam::PointCloud>(*std::move(cloud));
  }
  TrajectoryNodes out;
  out.resident = false;
  out.scans_processed = feed.scans_processed;
  out.loops = std::move(poses->loops);
  out.nodes = std::move(poses->nodes);
  for (laser_slam::NodeView& node : out.nodes) {
    auto it = points.find(node.scan);
    if (it == points.end() || it->second == nullptr) {
      return absl::DataLossError(
          absl::StrCat("a shared map's node feed has no points for its node at scan ", node.scan));
    }
    node.points = it->second;
  }
  return out;
}

}  // namespace waymark::service
