#ifndef WAYMARK_STORAGE_MAP_STORE_H_
#define WAYMARK_STORAGE_MAP_STORE_H_

// Maps shared by robots (issue 38): a named map, its revision and its trajectories, each one SLAM
// session's (slam_store.h) nodes, with where that session's own frame lies in the map frame once
// the trajectory is tied in, and what the follow after the tie observed (opaque to the store).
// With several servers on one database, one server at a time holds a map's lease: it ties,
// follows and optimises the map's trajectories (the service's map_tie_worker.h).

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "storage/slam_store.h"

namespace waymark::storage {

// Where a trajectory's frame (its session's map frame) lies in the shared map's frame.
struct MapTie {
  double x = 0;
  double y = 0;
  double theta = 0;
};

struct MapTrajectoryRecord {
  std::string session_id;
  int64_t ordinal = 0;   // the join order within the map: 1, 2, 3, ...
  double joined_at = 0;  // unix seconds
  std::optional<MapTie> tie;  // unset = not yet in the map
  // The follow's origin samples after the tie (and the searches that found it), encoded by the
  // service (map_follow_codec.h); empty: none (a tie with no searches counted here: a known
  // start, or one stored before the searches were kept).
  std::string follow;
  // Read-only, from the session's row.
  std::string robot_id;
  SlamSessionState session_state = SlamSessionState::kOpen;
  int64_t scans_processed = 0;
};

struct MapRecord {
  std::string name;
  double created_at = 0;  // unix seconds
  double updated_at = 0;
  // Counts the changes of what the map holds: trajectories joining, tied in, leaving.
  int64_t revision = 0;
  std::vector<MapTrajectoryRecord> trajectories;  // in join order
  // The server that ties and follows the map's trajectories (empty owner: none holds it). Taken
  // and renewed as a session's lease is (SlamLease): by the database's clock, expiring unless
  // renewed, so a dead owner's maps pass to another server.
  SlamLease lease;
};

// A trajectory's nodes as the server its robot streams to publishes them for the map's owner on
// a fleet (the service's map_tie_worker.h), between the session's checkpoints: the nodes' poses
// and loops (`poses`, rewritten at each publish) and each node's points (one row a node, written
// once, by the node's scan). Opaque to the store (laser_slam/mapping/node_feed_codec.h).
struct FeedNodePoints {
  int64_t scan = 0;
  std::string points;
};
struct TrajectoryFeedUpdate {
  int64_t scans_processed = 0;  // the session's, when its nodes were read
  std::string poses;
  std::vector<FeedNodePoints> added;  // nodes new since the last publish
  std::vector<int64_t> dropped;       // nodes gone since (pruned), by scan
  // This server's first publish of the session: every row of points there was goes first (a
  // server that served the robot before may have left nodes this one never had).
  bool replace = false;
};
struct TrajectoryFeed {
  int64_t version = 0;  // counts the publishes
  int64_t scans_processed = 0;
  std::string poses;
  std::vector<FeedNodePoints> points;  // the rows asked for (ReadTrajectoryFeed), by scan
};

// Every mutating call is one transaction, and each returns the map as it stands after it.
// The map frame is its first trajectory's: a trajectory that joins (or, when the tied-in ones
// left, remains in) a map with no trajectory tied in is tied in at the origin, in the same
// transaction, so that two robots joining an empty map at once cannot both define it.
// Errors: INVALID_ARGUMENT (a bad name: CheckMapName; a non-finite tie), NOT_FOUND (unknown map or
// session), ALREADY_EXISTS (a name taken; a session already in a map, which may hold one only),
// INTERNAL / UNAVAILABLE / DATA_LOSS as SlamStore's.
class MapStore {
 public:
  virtual ~MapStore() = default;

  // A new, empty map at revision 0.
  virtual absl::StatusOr<MapRecord> CreateMap(const std::string& name) = 0;
  virtual absl::StatusOr<MapRecord> GetMap(const std::string& name) = 0;
  // Every map, by name (byte order).
  virtual absl::StatusOr<std::vector<MapRecord>> ListMaps() = 0;
  // Session `session_id` joins the map as its next trajectory (revision + 1).
  virtual absl::StatusOr<MapRecord> AddTrajectory(const std::string& map,
                                                  const std::string& session_id) = 0;
  // Ties the trajectory in at `tie` (or moves it there) and stores `follow` (MapTrajectoryRecord;
  // empty for a new tie), revision + 1. NOT_FOUND when the session has no trajectory in this map.
  virtual absl::StatusOr<MapRecord> TieTrajectory(const std::string& map,
                                                  const std::string& session_id,
                                                  const MapTie& tie,
                                                  const std::string& follow) = 0;
  // The session left the map (it was deleted: deleting a session removes its trajectory row with
  // it, so the row may be gone already): removes its row if there, revision + 1, and ties the
  // oldest remaining trajectory in at the origin when no tied-in one remains.
  virtual absl::StatusOr<MapRecord> RemoveTrajectory(const std::string& map,
                                                     const std::string& session_id) = 0;
  // Deletes the map and its trajectory rows (never the sessions). Returns it as it was.
  virtual absl::StatusOr<MapRecord> DeleteMap(const std::string& name) = 0;

  // Takes or renews the map's lease for `owner` (reachable at `address`) for `ttl_seconds`: the
  // lease as it now stands, `owner`'s, or another server's unexpired one (then nothing changed).
  // The revision does not change: the lease says who works on the map, not what it holds.
  virtual absl::StatusOr<SlamLease> AcquireMapLease(const std::string& map,
                                                    const std::string& owner,
                                                    const std::string& address,
                                                    double ttl_seconds) = 0;
  // Gives the lease up when `owner` holds it (a clean shutdown); OK otherwise.
  virtual absl::Status ReleaseMapLease(const std::string& map, const std::string& owner) = 0;

  // Publishes a session's nodes (one transaction): the feed's version + 1, returned. NOT_FOUND
  // for an unknown session. The feed goes with its session (deleting the session deletes it).
  virtual absl::StatusOr<int64_t> PublishTrajectoryFeed(const std::string& session_id,
                                                        const TrajectoryFeedUpdate& update) = 0;
  // The session's feed when its version is above `after_version`, with the points of its nodes
  // whose scan is above `after_scan`; nullopt when it has none or none newer.
  virtual absl::StatusOr<std::optional<TrajectoryFeed>> ReadTrajectoryFeed(
      const std::string& session_id, int64_t after_version, int64_t after_scan) = 0;
};

// A SQLite file's map store (see OpenSqliteSlamStore; it may share the file).
absl::StatusOr<std::unique_ptr<MapStore>> OpenSqliteMapStore(const std::string& path);

}  // namespace waymark::storage

#endif  // WAYMARK_STORAGE_MAP_STORE_H_
