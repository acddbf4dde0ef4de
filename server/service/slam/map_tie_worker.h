#ifndef WAYMARK_SERVER_SERVICE_SLAM_MAP_TIE_WORKER_H_
#define WAYMARK_SERVER_SERVICE_SLAM_MAP_TIE_WORKER_H_

// Ties robots into their shared maps (issue 38; docs/laser-slam.md, "Maps shared by robots"):
// for every session of a map that is not yet in it, the search of laser_slam::TrajectoryTie
// (server/laser_slam/mapping/trajectory_tie.h) over what the map's tied-in trajectories hold,
// and on success the tie, stored (MapStore::TieTrajectory, the map's revision + 1), after which
// the robot's answers carry its map-frame pose.
//
// On its own thread, never on a session's strand: no answer waits on it. It reads the sessions
// only through snapshots of their nodes (MappingBackend::Nodes, which the back end serves from
// any thread; a closed session's once, from its checkpoint). Rate-limited as the localizer's
// global search is: each joining session grants TieOptions::reads_per_scan cell reads for every
// scan it processed (4 M reads are 5-10 ms here, a scan period 25-200 ms), or reads_per_second
// for the seconds of its stamps where that is more (keyframe logs: search_clock.h), and the
// searches run on that clock of scans (trajectory_tie.h), so a replay faster than real time is tied in at the
// scan a robot at its pace would be, the thread catching up after it.

#include <condition_variable>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "server/laser_slam/mapping/mapping_backend.h"
#include "server/laser_slam/mapping/trajectory_follow.h"
#include "server/laser_slam/mapping/trajectory_tie.h"
#include "server/service/slam/folder.h"
#include "server/service/slam/trajectory_feed.h"
#include "server/service/slam/trajectory_nodes.h"
#include "storage/map_store.h"

namespace waymark::service {

class MapTieWorker {
 public:
  struct Sources {
    // The maps with a trajectory tied in and one not yet (MapRegistry::MapsToTie).
    std::function<std::vector<storage::MapRecord>()> maps_to_tie;
    // A session's nodes (SessionQueries::TrajectoryNodesOf).
    std::function<absl::StatusOr<TrajectoryNodes>(const std::string& session_id)> nodes;
    // Whether the session is in memory here. Otherwise its nodes are read from its checkpoint,
    // again only once the map's record shows more scans processed (its robot goes on on another
    // server of the fleet, which checkpoints it).
    std::function<bool(const std::string& session_id)> resident;
    // Whether this server ties and follows the map's robots now (MapRegistry::Own: the map's
    // lease on a fleet); null: always.
    std::function<bool(const std::string& map)> own;
    // A session's follow as stored with the map (MapRegistry::FollowedSamples): what this server
    // goes on from when it starts following a robot another server (or this one before a
    // restart) followed; null or empty: from its tie.
    std::function<std::vector<laser_slam::OriginSample>(const std::string& session_id)> samples;
    // Stores the tie and updates the answers (MapRegistry::Tie).
    std::function<absl::Status(const std::string& map, const std::string& session_id,
                               const storage::MapTie& tie)>
        tie;
    // After the tie (both may be null: no following). The maps with two trajectories tied in or
    // more (MapRegistry::MapsToFollow), and a followed session's origin samples, all of them
    // each time one is added (MapRegistry::Follow).
    std::function<std::vector<storage::MapRecord>()> maps_to_follow;
    std::function<absl::Status(const std::string& map, const std::string& session_id,
                               const std::vector<laser_slam::OriginSample>& samples,
                               const laser_slam::FollowProgress& progress)>
        follow;
    // On a fleet (both null elsewhere): publishes the nodes of a session in memory here whose map
    // another server owns (MapStore::PublishTrajectoryFeed), and reads the nodes another server
    // published of a session of a map owned here (MapStore::ReadTrajectoryFeed), between the
    // session's checkpoints (trajectory_feed.h).
    std::function<absl::StatusOr<int64_t>(const std::string& session_id,
                                          const storage::TrajectoryFeedUpdate& update)>
        publish;
    // The maps whose sessions in memory here are published unless this server holds the map's
    // lease (MapRegistry::MapsWithOthers; `holds`: MapRegistry::Holds, which never takes it).
    std::function<std::vector<storage::MapRecord>()> maps_to_publish;
    std::function<bool(const std::string& map)> holds;
    std::function<absl::StatusOr<std::optional<storage::TrajectoryFeed>>(
        const std::string& session_id, int64_t after_version, int64_t after_scan)>
        read_feed;
    // How the searches for a session not yet in its map go, after each one (may be null).
    std::function<void(const std::string& session_id, const laser_slam::TieProgress& progress)>
        searched;
  };
  struct Options {
    double poll_seconds = 0.2;
    laser_slam::TieOptions tie;  // its reads_per_scan is the budget
    // A tie found is kept only when the map's self-check with the robot placed there finds no
    // more contradicting areas than before (laser_slam::TieKeepsTheMapConsistent).
    bool verify_ties = true;
    // Every tied-in trajectory but the map frame's first is matched again in local windows
    // against the others (laser_slam::TrajectoryFollow): its origin becomes piecewise.
    bool follow = true;
    laser_slam::FollowOptions follow_options;
    // A session's nodes are published for its map's owner at most this often (s), when they
    // changed (with Sources::publish).
    double feed_seconds = 1.0;
  };

  // Starts the thread.
  MapTieWorker(Sources sources, Options options);
  ~MapTieWorker();  // Stop()
  MapTieWorker(const MapTieWorker&) = delete;
  MapTieWorker& operator=(const MapTieWorker&) = delete;
  // Stops the thread (a search under way is dropped; it starts again after a restart).
  void Stop();

 private:
  struct Joining {
    std::string map;
    std::unique_ptr<laser_slam::TrajectoryTie> tie;
  };
  void Loop();
  // One pass over the maps to tie; true when some session still has work it could do now.
  bool Pass();
  // Publishes the nodes of the sessions in memory here whose map (of `maps`) another server owns,
  // when due.
  void PublishPass(const std::vector<storage::MapRecord>& maps);
  // One joining session's turn: spends some of its budget, ties it in when found; true when it
  // has more to do now.
  bool Turn(const std::string& map, const storage::MapTrajectoryRecord& trajectory,
            const std::vector<laser_slam::TiedTrajectory>& tied, std::size_t map_nodes);
  absl::StatusOr<TrajectoryNodes> NodesOf(const storage::MapTrajectoryRecord& trajectory);
  // Whether the trajectory's nodes may have changed since they were last read: its session is in
  // memory here, or its record shows more scans than the checkpoint read.
  // A session another server publishes (Sources::read_feed) may have moved while it is open.
  bool Moving(const storage::MapTrajectoryRecord& trajectory) const;
  // The nodes another server published of `trajectory`'s session, joined onto those held; nullopt
  // when there is no feed, none newer, or one behind the session's checkpoint.
  std::optional<TrajectoryNodes> FedNodesOf(const storage::MapTrajectoryRecord& trajectory);
  bool Owned(const std::string& map) const { return !sources_.own || sources_.own(map); }
  // The following after the tie: one pass over the maps to follow; true when some session has
  // more to do now. `referenced`: the sessions whose nodes it read.
  bool FollowPass(std::set<std::string>* referenced);
  // One followed trajectory's turn: `all` are the map's tied-in trajectories, `self` its index.
  bool FollowTurn(const std::string& map, const storage::MapTrajectoryRecord& trajectory,
                  const std::vector<laser_slam::TiedTrajectory>& all, std::size_t self);
  // The samples of a followed session (empty: none).
  std::vector<laser_slam::OriginSample> SamplesOf(const std::string& session_id) const;

  const Sources sources_;
  const Options options_;
  // The thread's own (no lock): the sessions being searched for, and the nodes of sessions read
  // from their checkpoints, with the scans processed their record showed then.
  std::map<std::string, Joining> joining_;
  struct Stored {
    TrajectoryNodes nodes;
    int64_t scans_processed = 0;
    int64_t feed_version = 0;  // the feed's version read last (0: none)
  };
  std::map<std::string, Stored> stored_;
  // Closed sessions searched to their last scan without a tie, with the map's nodes then: their
  // search (and its grids, megabytes) is dropped, and run again only once the map has grown by
  // TieOptions::map_growth or the robot resumes its session.
  std::map<std::string, std::size_t> exhausted_;
  // Tied-in sessions followed after their tie; `done`: closed and matched to its last node.
  struct Following {
    std::string map;
    std::unique_ptr<laser_slam::TrajectoryFollow> follow;
    bool done = false;
  };
  std::map<std::string, Following> following_;
  // The sessions whose nodes this server publishes, with when (steady clock, s) it last did.
  struct Publishing {
    FeedPublisher publisher;
    double at = -1e9;
  };
  std::map<std::string, Publishing> publishing_;
  std::mutex mu_;
  std::condition_variable cv_;
  bool stop_ = false;
  std::thread thread_;
};

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_SLAM_MAP_TIE_WORKER_H_
