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
// stream opens here, and one server at a time ties and follows a map's trajectories: the one
// holding the map's lease (Own). The others read the ties and follows it stores.

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
#include "server/laser_slam/mapping/map_graph_cache.h"
#include "server/laser_slam/mapping/mapping_backend.h"
#include "server/laser_slam/mapping/trajectory_follow.h"
#include "server/laser_slam/mapping/trajectory_tie.h"
#include "server/service/slam/folder.h"
#include "server/service/slam/session_leases.h"
#include "server/service/slam/trajectory_nodes.h"
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
  // FAILED_PRECONDITION). `leases` (not owned; null or disabled: one server per database, which
  // owns every map): this server's identity on a fleet, whose sessions may have joined their
  // maps on another server (looked up in the store) and whose maps are leased (Own).
  MapRegistry(storage::MapStore* store, SessionLeases* leases) : store_(store), leases_(leases) {}

  // How the map's grid, segment map and node_origins place its trajectories: true, one pose
  // graph over all of them (laser_slam/mapping/map_graph.h: a loop one robot left open is closed
  // by the robot that drives it); false, one at a time, each followed robot bent to meet the
  // others (CurrentOrigins). Set before serving.
  void set_map_graph(bool on) { map_graph_ = on; }

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
  using SessionNodes = std::function<absl::StatusOr<TrajectoryNodes>(const std::string& id)>;
  absl::StatusOr<v1::MapOccupancyGrid> GetMapGrid(const std::string& name,
                                                  std::optional<double> resolution,
                                                  const SessionGrid& session_grid,
                                                  const SessionNodes& session_nodes);

  // The map's segment map: each tied-in trajectory's segments (`session_segments`, its
  // session's GetMap) moved into the map frame where each was last seen (by its nodes,
  // `session_nodes`, and origin samples), and a wall several robots mapped fused into one
  // (laser_slam/mapping/map_segments.h).
  using SessionSegments =
      std::function<absl::StatusOr<v1::SegmentMap>(const std::string& id)>;
  absl::StatusOr<v1::MapSegmentMap> GetMapSegments(const std::string& name,
                                                   const SessionSegments& session_segments,
                                                   const SessionNodes& session_nodes);

  // GetMap, with each followed trajectory's node_origins (CurrentOrigins of its session's
  // nodes, `session_nodes`; with the map's graph, every tied-in trajectory's, the map frame's
  // too); a trajectory whose nodes cannot be read keeps origin_samples only.
  absl::StatusOr<v1::Map> GetMapWithNodeOrigins(const std::string& name,
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
  // The maps, as stored, of the sessions known here that hold other trajectories too: on a fleet
  // the tie worker publishes the nodes of those in memory here for the map's owner
  // (trajectory_feed.h) when another server owns it.
  std::vector<storage::MapRecord> MapsWithOthers();
  // The session's piecewise origin after its tie (trajectory_follow.h), in memory: map-frame poses
  // and the map's grid use the origin at each pose's stamp. The store keeps the latest origin and
  // the samples with their counts (`progress`), written at the first follow and again when the
  // origin moved by more than a few cm or 10 more samples came (revision + 1 then).
  absl::Status Follow(const std::string& map, const std::string& session_id,
                      const std::vector<laser_slam::OriginSample>& samples,
                      const laser_slam::FollowProgress& progress);
  // How the searches for a session not yet in its map went (MapTrajectory.search; in memory).
  void Searched(const std::string& session_id, const laser_slam::TieProgress& progress);
  // A followed session's samples (empty: none), as this server follows it or as the map's owner
  // stored them.
  std::vector<laser_slam::OriginSample> FollowedSamples(const std::string& session_id) const;

  // Whether this server may tie and follow the map's trajectories now: always on a single server;
  // on a fleet when it holds the map's lease, taken when free or expired and renewed every third
  // of its ttl. A lease lost to another server is logged, and the map's samples are read from
  // the store again from then on.
  bool Own(const std::string& map);
  // Whether this server holds the map's lease now, as far as it knows (no store call, and never
  // taking it): what it asks before publishing its robots' nodes for the map's owner.
  bool Holds(const std::string& map) const;
  // How often the map's graph was solved and its kept solution reused (map_graph_cache.h);
  // nullopt before the first read that placed the map by its graph.
  std::optional<laser_slam::MapGraphCache::Stats> GraphStats(const std::string& name) const;

  // Gives up the maps' leases this server holds (a clean shutdown: the next owner need not wait
  // for them to expire).
  void ReleaseLeases();

 private:
  absl::Status CheckStore() const;
  // Records what `map` says about its sessions' memberships.
  void Remember(const storage::MapRecord& map);
  // The map's graph with its kept solution (created on first use); null with map_graph_ off.
  std::shared_ptr<laser_slam::MapGraphCache> Graph(const std::string& name);

  bool fleet() const { return leases_ != nullptr && leases_->enabled(); }
  // The maps (read from the store, and remembered) of the members for which `member` holds, kept
  // where `keep` holds.
  std::vector<storage::MapRecord> StoredMapsOf(
      const std::function<bool(const MapMembership&)>& member,
      const std::function<bool(const storage::MapRecord&)>& keep);

  storage::MapStore* const store_;
  SessionLeases* const leases_;
  bool map_graph_ = true;
  mutable std::mutex mutex_;  // guards members_, followed_, searches_, owned_, graphs_
  std::map<std::string, std::shared_ptr<MapMembership>> members_;  // by session id
  // Followed trajectories: their origin samples, and the origin and sample count last written to
  // the store. `here`: followed by this server (the store's copy is older); otherwise the store's
  // as of map revision `revision`.
  struct Followed {
    std::vector<laser_slam::OriginSample> samples;
    laser_slam::Pose2 stored;
    std::size_t stored_count = 0;
    bool here = false;
    int64_t revision = -1;
    v1::MapMatchStats stats;  // counted in all, `base` by the follows before this server's
    v1::MapMatchStats base;
    v1::MapMatchStats search;  // the searches up to its tie (StoredFollow::search)
  };
  std::map<std::string, Followed> followed_;  // by session id; guarded by mutex_
  // Sessions searched for here and not yet tied in: how the searches went.
  std::map<std::string, v1::MapMatchStats> searches_;  // guarded by mutex_
  // The map's graphs with their kept solutions, by map name; guarded by mutex_ (each cache guards its own solution).
  std::map<std::string, std::shared_ptr<laser_slam::MapGraphCache>> graphs_;
  // The maps whose lease this server holds, with when (steady clock, s) to renew it.
  std::map<std::string, double> owned_;  // guarded by mutex_
  // Fills each tied-in trajectory's origin_samples (`map` is `record` as ToProto made it): this
  // server's own follow, else the one stored with the map.
  void AddSamples(const storage::MapRecord& record, v1::Map* map) const;
};

// The map frame pose of `pose` (a session frame pose) for a trajectory tied in at `tie`.
v1::Pose2D InMapFrame(const storage::MapTie& tie, const v1::Pose2D& pose);

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_SLAM_MAP_REGISTRY_H_
