#ifndef WAYMARK_SERVER_SERVICE_SLAM_MAP_REGISTRY_H_
#define WAYMARK_SERVER_SERVICE_SLAM_MAP_REGISTRY_H_

// Maps shared by robots (issue 38; docs/laser-slam.md, "Maps shared by robots"): the part of the
// SLAM registry that several sessions share, beside the session table and the lifecycle (the
// facade, slam_registry.h, wires it in). A map is named and stored (storage/map_store.h); a laser
// session joins one when it is created, as one more trajectory. The map frame is its first
// trajectory's, tied in at once; the others are "not yet in the map" until the tie worker
// (map_tie_worker.h) finds them in it from their scans, or CreateSessionRequest.initial_map_pose
// puts them there, and calls Tie.
//
// What the answers need is kept in memory per session in a map (MapMembership), shared with that
// session's streams so that each answer is decorated without a lookup; it is read from the store
// at start-up (Load) and kept current by the changes made here. With several servers on one
// database (leases), a session that joined on another server is found in the store when its
// stream opens here.

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "server/laser_slam/mapping/mapping_backend.h"
#include "server/laser_slam/mapping/trajectory_follow.h"
#include "server/service/slam/folder.h"
#include "storage/map_store.h"
#include "waymark/v1/slam.pb.h"

namespace waymark::service {

// A session's place in its map, as its answers carry it (v1::MapPose). Thread-safe.
class MapMembership {
 public:
  explicit MapMembership(std::string map) : map_(std::move(map)) {}
  // Sets update->map_pose from the update's pose (the session's frame). Nothing for an update
  // without a pose, or once the session left its map (the map was deleted).
  void Decorate(v1::SlamUpdate* update) const;
  void Set(std::optional<storage::MapTie> tie, int64_t revision);
  void Detach();
  std::string map() const;
  bool tied_in() const;
  // Where the session's frame lies in the map frame (the latest origin); unset until tied in.
  std::optional<storage::MapTie> tie() const;

 private:
  mutable std::mutex mutex_;
  std::string map_;  // empty once detached
  std::optional<storage::MapTie> tie_;
  int64_t revision_ = 0;
};

class MapRegistry {
 public:
  // `store` is not owned and may be null: a server without maps (every map call is then
  // FAILED_PRECONDITION). `find_in_store`: look a session up in the store when it is in no map
  // known here (several servers on one database).
  MapRegistry(storage::MapStore* store, bool find_in_store)
      : store_(store), find_in_store_(find_in_store) {}

  // Reads every map's trajectories (at start-up).
  absl::Status Load();

  absl::StatusOr<v1::Map> CreateMap(const std::string& name);
  absl::StatusOr<v1::Map> GetMap(const std::string& name);
  absl::StatusOr<v1::ListMapsResponse> ListMaps();
  // FAILED_PRECONDITION when an open session is in the map, unless `force`, which detaches them.
  absl::StatusOr<v1::DeleteMapResponse> DeleteMap(const std::string& name, bool force);
  // The map's grid (MapOccupancyGrid, slam.proto). One trajectory tied in at the origin: its
  // session's grid, which `session_grid` renders. Otherwise every tied-in trajectory's nodes
  // (`session_nodes`), moved into the map frame by its origin, cast into one grid: the rays of
  // all robots add their evidence in log odds, so a wall one robot saw and another saw through
  // (a door opened since) is weighed, not drawn twice.
  using SessionGrid = std::function<absl::StatusOr<v1::OccupancyGrid>(const std::string& id)>;
  using SessionNodes =
      std::function<absl::StatusOr<std::vector<laser_slam::NodeView>>(const std::string& id)>;
  absl::StatusOr<v1::MapOccupancyGrid> GetMapGrid(const std::string& name,
                                                  std::optional<double> resolution,
                                                  const SessionGrid& session_grid,
                                                  const SessionNodes& session_nodes);

  // Whether `request` may join its map (request.map() set): a laser mapping session with loop
  // closure, a valid name of a map that exists. Checked before the session is created.
  absl::Status CheckJoin(const v1::CreateSessionRequest& request);
  // The created session joins the map; returns the map as it now stands.
  absl::StatusOr<v1::Map> Join(const std::string& name, const std::string& session_id);
  // The session was deleted: its trajectory leaves its map (if it was in one). Logged, not
  // returned: the session is gone either way.
  void SessionDeleted(const std::string& session_id);

  // The session's membership, shared with its streams; null when it is in no map.
  std::shared_ptr<MapMembership> Membership(const std::string& session_id);
  // The map the session is in; empty when none. Known sessions only (no store lookup).
  std::string MapOf(const std::string& session_id) const;
  // The sessions known here that are tied into `map`, with their current origins (the latest
  // followed one): what several robots exploring the map share (exploration_team.h).
  std::vector<std::pair<std::string, storage::MapTie>> TiedMembers(const std::string& map) const;

  // What the tie worker searches (map_tie_worker.h): the maps, as stored, where a session known
  // here is not yet tied in. No store read while every known session is tied in.
  std::vector<storage::MapRecord> MapsToTie();
  // Ties the session's trajectory in at `tie` (MapStore::TieTrajectory: revision + 1); its
  // answers then carry its map-frame pose.
  absl::Status Tie(const std::string& map, const std::string& session_id,
                   const storage::MapTie& tie);
  // The maps, as stored, where a session known here is tied in beside other tied-in trajectories:
  // what the tie worker follows after a tie (laser_slam::TrajectoryFollow).
  std::vector<storage::MapRecord> MapsToFollow();
  // The session's piecewise origin after its tie (trajectory_follow.h), in memory: map-frame poses
  // and the map's grid use the origin at each pose's stamp. The store keeps one origin, the
  // latest, written again when it moved by more than a few cm (revision + 1 then).
  absl::Status Follow(const std::string& map, const std::string& session_id,
                      const std::vector<laser_slam::OriginSample>& samples);

 private:
  absl::Status CheckStore() const;
  // Records what `map` says about its sessions' memberships.
  void Remember(const storage::MapRecord& map);

  storage::MapStore* const store_;
  const bool find_in_store_;
  mutable std::mutex mutex_;  // guards members_
  std::map<std::string, std::shared_ptr<MapMembership>> members_;  // by session id
  // Followed trajectories: their origin samples, and the origin last written to the store.
  struct Followed {
    std::vector<laser_slam::OriginSample> samples;
    laser_slam::Pose2 stored;
  };
  std::map<std::string, Followed> followed_;  // by session id; guarded by mutex_
  // Fills each trajectory's origin_samples from followed_.
  void AddSamples(v1::Map* map) const;
  // A followed session's samples (empty: not followed here).
  std::vector<laser_slam::OriginSample> FollowedSamples(const std::string& session_id) const;
};

// The map frame pose of `pose` (a session frame pose) for a trajectory tied in at `tie`.
v1::Pose2D InMapFrame(const storage::MapTie& tie, const v1::Pose2D& pose);

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_SLAM_MAP_REGISTRY_H_
