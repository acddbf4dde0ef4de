#ifndef WAYMARK_SERVER_SERVICE_SLAM_SESSION_QUERIES_H_
#define WAYMARK_SERVER_SERVICE_SLAM_SESSION_QUERIES_H_

// What SLAM sessions answer to readers: a session's description, its map, trajectory and
// occupancy grid, the list of a robot's sessions. A session that is not resident is read from the
// store (its engine rebuilt from the checkpoint when the answer needs it), never made resident.

#include <memory>
#include <optional>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "server/service/slam/folder.h"
#include "server/service/slam/map_tie_worker.h"
#include "server/service/slam/slam_session.h"
#include "storage/slam_store.h"
#include "waymark/v1/slam.pb.h"

namespace waymark::service {

class SessionPersistence;
class SessionTable;

// The API's Session for a stored record; a resident session's own counters and queue replace the
// stored ones.
v1::Session DescribeSession(const storage::SlamSessionRecord& record, SlamSession* resident);

class SessionQueries {
 public:
  // None is owned; all must outlive this.
  SessionQueries(storage::SlamStore* store, const SessionTable* table,
                 SessionPersistence* persistence)
      : store_(store), table_(table), persistence_(persistence) {}

  // SlamRegistry's reads (slam_registry.h).
  absl::StatusOr<v1::Session> GetSession(const std::string& session_id);
  absl::StatusOr<v1::SegmentMap> GetMap(const std::string& session_id);
  absl::StatusOr<v1::Trajectory> GetTrajectory(const std::string& session_id);
  absl::StatusOr<v1::OccupancyGrid> GetOccupancyGrid(const std::string& session_id,
                                                     std::optional<double> resolution);
  absl::StatusOr<v1::ListSessionsResponse> ListSessions(const std::string& robot_id);
  // A laser session's nodes, for tying it into its shared map (map_tie_worker.h): a resident
  // session's without taking its engine lock (the back end serves them from any thread, so the
  // strand never waits on this), a stored one's from its checkpoint. FAILED_PRECONDITION for a
  // visual session.
  absl::StatusOr<TrajectoryNodes> TrajectoryNodesOf(const std::string& session_id);
  bool IsResident(const std::string& session_id) const;

 private:
  // A session to read from: the resident one, or one built from its checkpoint (not made
  // resident); `visual_refusal` for a stored visual session (its engine is not built to read it).
  absl::StatusOr<std::shared_ptr<SlamSession>> SessionToRead(const std::string& session_id,
                                                             const absl::Status& visual_refusal);

  storage::SlamStore* const store_;
  const SessionTable* const table_;
  SessionPersistence* const persistence_;
};

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_SLAM_SESSION_QUERIES_H_
