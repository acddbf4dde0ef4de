#ifndef WAYMARK_SERVER_SERVICE_SLAM_SLAM_REGISTRY_H_
#define WAYMARK_SERVER_SERVICE_SLAM_SLAM_REGISTRY_H_

// The SLAM sessions a server holds, laser (METHODS.md section 2) and visual (section 3): each one
// in memory (its engine, its input queue) and in the store (config, counters, checkpoints,
// trajectory). Application layer between the gRPC handlers and the engines + storage: it speaks
// the API's messages but no gRPC, so it is tested without a server. What differs per kind lives
// behind SessionEngine (session_engine.h); queues, strands, time order, counters, checkpoints and
// limits below are the same for both.
//
// Threading. Every session has a bounded FIFO of accepted messages and is processed in order on
// its own strand: at most one worker runs a session at a time, and a worker takes at most
// `max_batch` messages of one session before it serves the next session that has work (round
// robin, so one fast robot cannot starve the others). The workers are a fixed pool shared by all
// sessions (`workers`, default the hardware threads). Results go to the stream's sink on the worker
// thread, in message order.
//
// Admission (checked by Submit on the caller's thread, before a message is queued, so a bad message
// is answered at once and never reaches the engine):
//   - the payload suits the session's kind and converts. Laser: finite stamps and poses, a valid
//     beam geometry, the range count equal to the geometry's beam_count, at most kMaxScanBeams
//     beams. Visual: a finite stamp, a JPEG/PNG image of the camera's size, an optional 16-bit
//     single-channel PNG depth of the same size, finite boxes (visual_frame_decoder.h; frames are
//     decoded here, on the stream's thread, which paces a robot that sends faster than it can be
//     decoded without holding up other sessions). Else INVALID_ARGUMENT;
//   - per-sensor time order: an odometry (scan or frame) stamp must be greater than the last
//     accepted odometry (scan or frame) stamp, including the stamps restored from the checkpoint after a restart:
//     else INVALID_ARGUMENT, and the session's state is unchanged;
//   - queue policy: when `queue_capacity` messages are already waiting, the message is rejected
//     with RESOURCE_EXHAUSTED and counted in messages_dropped. Nothing is ever dropped silently
//     and nothing already accepted is discarded: the client sees exactly which messages were not
//     taken (by sequence) and may resend them. A client that keeps at most `queue_capacity`
//     messages outstanding (sent after the last answered scan) never sees RESOURCE_EXHAUSTED.
//     Visual sessions also bound the decoded frames waiting to `max_queued_frame_bytes` (a frame
//     that finds the queue empty is always taken), answered the same way.
// NaN, infinite, negative and zero ranges are passed through; the engine treats them as
// no-returns. An error the engine returns for one message is answered as a rejection for that
// message; the session goes on.
//
// Checkpoints (engine state + counters + the trajectory poses not yet stored, one transaction;
// visual sessions store 3-D poses and resume tracking at the last one, visual_session_engine.h):
// after every `checkpoint_scans` processed scans, when `checkpoint_seconds` have passed since the
// last checkpoint of a session with unsaved work (checked after each scan and by a timer for idle
// sessions), when the journal since the last checkpoint holds `checkpoint_journal_bytes`, on
// CloseSession and on Shutdown.
//
// Journal (slam_journal.h): every accepted message is stored (one transaction for whatever all
// sessions accepted meanwhile) before it is processed, so before it is answered. After a restart,
// OpenStream on an open session that is not in memory loads it from its checkpoint and the stored
// trajectory and replays the journal after the checkpoint: the session holds every message the
// server accepted, as if it had not stopped (the engines are deterministic and their checkpoints
// exact: a laser session resumed with loop closure on ends bit-identical to an uninterrupted one). A
// message the journal cannot store (the database fails `attempts` times) is answered with that
// error and not processed. `journal = false` gives the old behaviour: messages accepted after the
// last checkpoint are lost with the process, and the client may resend them.
//
// CreateSession takes exactly one of a laser and a visual config (neither: a laser session with
// the defaults); a visual session's detector is built there, so a bad model is INVALID_ARGUMENT
// and nothing is stored. GetMap on a visual session is FAILED_PRECONDITION (no segment map);
// GetTrajectory returns its poses in pose3d.
//
// Leases (several servers on one database, session_leases.h): a session becomes resident only on
// the server that takes its lease (CreateSession, OpenStream, CloseSession of a session not in
// memory); another server's OpenStream gets FAILED_PRECONDITION naming the holder's address. The
// lease thread renews the resident sessions' leases; a session whose lease another server took
// over meanwhile is dropped from memory unsaved (its checkpoints are fenced by the lease, so it
// could not overwrite its successor's anyway) and its stream ends UNAVAILABLE. Shutdown
// releases the leases after the last checkpoint, so another server can take over at once.
//
// Limits: `max_sessions` open sessions per server (CreateSession: RESOURCE_EXHAUSTED beyond it;
// only open sessions are held in memory, so this also bounds memory together with the queue
// capacity and kMaxScanBeams), robot_id and name lengths, one stream per session (the newest:
// OpenStream takes the session over from an older stream).
//
// The parts (one class each, owned here; this class only wires them and orders Shutdown):
//   - slam_session.h      the session's state in memory, shared by all parts;
//   - session_table.h     the resident sessions by id;
//   - session_lifecycle.h create, import, load (taking the lease), close, delete, lease renewal;
//   - session_streams.h   stream ownership and handover, admission, the answers;
//   - session_scheduler.h the worker pool and the periodic threads;
//   - session_persistence.h engines from the store, journal replay, checkpoints;
//   - session_queries.h   descriptions, maps, trajectories, grids, lists;
//   - map_registry.h      maps shared by robots (issue 38): what several sessions share. A
//                         session joins one at creation (CreateSessionRequest.map); its answers
//                         then carry map_pose; deleting the session takes it out of the map.
//   - map_tie_worker.h    finds a joined robot in its map from its scans and ties it in (its
//                         own thread: no answer waits on it).

#include <atomic>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "server/service/slam/folder.h"
#include "server/service/slam/session_leases.h"
#include "server/service/slam/slam_registry_options.h"
#include "server/service/slam/slam_stream.h"
#include "storage/map_store.h"
#include "storage/slam_store.h"
#include "waymark/v1/slam.pb.h"

namespace waymark::service {

class ExplorationTeam;
class MapRegistry;
class MapTieWorker;
class SessionLifecycle;
class SessionPersistence;
class SessionQueries;
class SessionScheduler;
class SessionStreams;
class SessionTable;
class SlamJournal;

class SlamRegistry {
 public:
  // One client stream attached to a session (see OpenStream; slam_stream.h).
  using Stream = SlamStream;

  // `maps` (optional) keeps the maps shared by robots; without it the map calls are
  // FAILED_PRECONDITION. Its maps are loaded here.
  static absl::StatusOr<std::unique_ptr<SlamRegistry>> Create(
      std::unique_ptr<storage::SlamStore> store, const SlamRegistryOptions& options = {},
      std::unique_ptr<storage::MapStore> maps = nullptr);
  ~SlamRegistry();  // Shutdown()
  SlamRegistry(const SlamRegistry&) = delete;
  SlamRegistry& operator=(const SlamRegistry&) = delete;

  // With request.map set the new session joins that map (map_registry.h): refused before
  // anything is stored when it cannot (MapRegistry::CheckJoin), and deleted again should the map
  // go before the join.
  absl::StatusOr<v1::Session> CreateSession(const v1::CreateSessionRequest& request);
  // Attaches a stream to an open session, loading it from its checkpoint when it is not in memory.
  // A stream already attached is taken over: it accepts nothing more (ABORTED), `cancel` of its
  // OpenStream is called (the service cancels its call), and the new stream attaches once the
  // messages the old one accepted are processed (answered through the old sink, if it still
  // writes).
  // NOT_FOUND (unknown id), FAILED_PRECONDITION (closed), UNAVAILABLE (shutting down, or the old
  // stream's messages not answered within stream_handover_wait), DATA_LOSS (unreadable checkpoint).
  absl::StatusOr<std::unique_ptr<Stream>> OpenStream(const std::string& session_id,
                                                     SlamUpdateSink sink,
                                                     std::function<void()> cancel = nullptr);
  // Final checkpoint, then CLOSED. FAILED_PRECONDITION when a stream is attached or it is closed.
  absl::StatusOr<v1::Session> CloseSession(const std::string& session_id);
  // Removes a session from memory and the store (checkpoint and trajectory, one transaction).
  // NOT_FOUND (unknown id); FAILED_PRECONDITION for an open session unless `force`, which closes
  // it first as CloseSession does (and so still refuses a session with a stream attached).
  absl::StatusOr<v1::DeleteSessionResponse> DeleteSession(const std::string& session_id,
                                                          bool force);
  absl::StatusOr<v1::Session> GetSession(const std::string& session_id);
  absl::StatusOr<v1::SegmentMap> GetMap(const std::string& session_id);
  absl::StatusOr<v1::Trajectory> GetTrajectory(const std::string& session_id);
  // The occupancy grid of a laser session (rendered from its kept scans, or its imported grid).
  // FAILED_PRECONDITION for a visual session or one without loop closure; INVALID_ARGUMENT for a
  // resolution outside [0.01, 1] m; RESOURCE_EXHAUSTED when the map needs a coarser resolution.
  absl::StatusOr<v1::OccupancyGrid> GetOccupancyGrid(const std::string& session_id,
                                                     std::optional<double> resolution);
  // Stores `request.grid` as a new closed laser session to localize on (INVALID_ARGUMENT naming
  // the field for a bad grid).
  absl::StatusOr<v1::Session> ImportMap(const v1::ImportMapRequest& request);
  absl::StatusOr<v1::ListSessionsResponse> ListSessions(const std::string& robot_id);

  // Maps shared by robots (map_registry.h; the RPCs of the same names in slam.proto).
  absl::StatusOr<v1::Map> CreateMap(const std::string& name);
  absl::StatusOr<v1::ListMapsResponse> ListMaps();
  // `node_origins`: with each followed trajectory's origin at every node (GetMapInfoRequest).
  absl::StatusOr<v1::Map> GetMapInfo(const std::string& name, bool node_origins = false);
  absl::StatusOr<v1::DeleteMapResponse> DeleteMap(const std::string& name, bool force);
  absl::StatusOr<v1::MapOccupancyGrid> GetMapOccupancyGrid(const std::string& name,
                                                           std::optional<double> resolution);
  absl::StatusOr<v1::MapSegmentMap> GetMapSegments(const std::string& name);

  // Checkpoints every resident session with unsaved work; returns the first error.
  absl::Status CheckpointAll();
  // Rejects new messages and streams (UNAVAILABLE), lets the queues drain, checkpoints every
  // resident session and stops the workers. Idempotent; the destructor calls it.
  absl::Status Shutdown();

  const SlamRegistryOptions& options() const { return options_; }

  // Sees every answer to a processed scan or frame (not rejections), on the session's worker
  // thread just before the stream's sink: the metrics' per-session counts and latencies (metrics.h).
  // Null (the default) = none. Safe to set and clear while sessions run.
  using UpdateObserver = SlamUpdateObserver;
  void SetUpdateObserver(UpdateObserver observer);
  // More watchers beside that one (the live view, server/service/live/): each sees every answer
  // as above and every admitted message (SlamInputObserver). Returns the id RemoveObserver takes;
  // safe to add and remove while sessions run.
  uint64_t AddObserver(SlamObserver observer);
  void RemoveObserver(uint64_t id);
  // Where robots reach this server, for the leases (SlamRegistryOptions::lease), once known.
  void set_lease_address(const std::string& address) { leases_.set_address(address); }

 private:
  SlamRegistry(std::unique_ptr<storage::SlamStore> store, const SlamRegistryOptions& options,
               std::unique_ptr<storage::MapStore> maps);

  const SlamRegistryOptions options_;
  std::unique_ptr<storage::SlamStore> store_;
  std::unique_ptr<storage::MapStore> map_store_;  // null: no maps
  std::atomic<bool> shutting_down_{false};
  SessionLeases leases_;
  std::unique_ptr<SlamJournal> journal_;  // null when options_.journal is off

  // The parts, each using only those above it (the scheduler calls back into the streams).
  std::unique_ptr<SessionTable> table_;
  std::unique_ptr<SessionPersistence> persistence_;
  std::unique_ptr<SessionLifecycle> lifecycle_;
  std::unique_ptr<SessionQueries> queries_;
  std::unique_ptr<SessionScheduler> scheduler_;
  std::unique_ptr<SessionStreams> streams_;
  std::unique_ptr<MapRegistry> maps_;
  std::shared_ptr<ExplorationTeam> team_;  // several robots exploring a map
  std::unique_ptr<MapTieWorker> tie_worker_;  // null without a map store

  std::mutex shutdown_mutex_;
  bool shut_down_ = false;
};

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_SLAM_SLAM_REGISTRY_H_
