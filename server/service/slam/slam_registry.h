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

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <optional>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "server/service/slam/folder.h"
#include "server/service/slam/session_engine.h"
#include "server/service/slam/session_leases.h"
#include "server/service/slam/slam_journal.h"
#include "server/service/slam/slam_params.h"
#include "storage/slam_store.h"
#include "waymark/v1/slam.pb.h"

namespace waymark::service {

struct QueuedMessage;  // an accepted message (slam_registry.cc)

struct SlamRegistryOptions {
  int queue_capacity = 64;        // messages waiting per session
  int workers = 0;                // 0 = std::thread::hardware_concurrency()
  double checkpoint_seconds = 30;  // 0 = no time-based checkpoints
  int checkpoint_scans = 500;     // 0 = no count-based checkpoints
  int max_sessions = 64;          // open sessions per server
  int max_batch = 8;              // messages of one session per turn of a worker
  // Store every accepted message before processing it (see Journal above).
  bool journal = true;
  // Checkpoint once the journal since the last checkpoint holds this many bytes (camera frames:
  // 30 s of 30 Hz RGB-D is several hundred MB), which bounds the replay after a crash.
  size_t checkpoint_journal_bytes = size_t{64} << 20;
  // Decoded frames waiting per visual session (640x480 RGB-D: 1.5 MB a frame).
  size_t max_queued_frame_bytes = size_t{64} << 20;
  // A stream opened while the session has one (the robot reconnected) waits this long for the
  // old stream's accepted messages to be answered, then takes the session over; UNAVAILABLE
  // after it.
  std::chrono::milliseconds stream_handover_wait{10000};
  // Several servers on one database (PostgreSQL): each session is served by the one holding its
  // lease (session_leases.h). Off (owner empty) with one server per database.
  SessionLeaseOptions lease;
  // Test hook: runs on the worker thread before each message of `session_id` is processed.
  std::function<void(const std::string& session_id)> before_process;
};

inline constexpr int kMaxRobotIdLength = 128;
inline constexpr int kMaxSessionNameLength = 256;

// Receives the answers of one stream, on a worker thread, one call at a time, in message order.
using SlamUpdateSink = std::function<void(const v1::SlamUpdate& update)>;

class SlamRegistry {
 private:
  struct Session;

 public:
  // One client stream attached to a session (see OpenStream). Not thread-safe: one thread (the
  // stream's reader) calls Submit and Close. Must not outlive the registry.
  class Stream {
   public:
    ~Stream();  // Close()
    Stream(const Stream&) = delete;
    Stream& operator=(const Stream&) = delete;

    const std::string& session_id() const;
    // What the session held when this stream attached (the API's StreamStart): loaded from its
    // checkpoint for this stream or already in memory, scans processed and the last one's stamp.
    const v1::StreamStart& start() const { return start_; }
    // OK: the message is queued and, if it is a scan, will be answered through the sink.
    // Otherwise the message was rejected (see the admission rules above) and the status says why.
    absl::Status Submit(const v1::SensorData& data);
    // Ends the stream's input without waiting: Submit is refused from now on, and another
    // stream's OpenStream takes the session over as soon as the messages this one accepted are
    // processed and answered (through this stream's sink). Idempotent.
    void StopAccepting();
    // StopAccepting, then waits until every accepted message has been processed and answered,
    // then detaches the sink (unless another stream has taken the session over). Idempotent.
    void Close();

   private:
    friend class SlamRegistry;
    Stream(SlamRegistry* registry, std::shared_ptr<Session> session, uint64_t epoch,
           v1::StreamStart start)
        : registry_(registry), session_(std::move(session)), epoch_(epoch),
          start_(std::move(start)) {}
    SlamRegistry* registry_;
    std::shared_ptr<Session> session_;
    const uint64_t epoch_;  // which of the session's streams this is (Session::stream_epoch)
    v1::StreamStart start_;
    bool stopped_ = false;
    bool closed_ = false;
  };

  static absl::StatusOr<std::unique_ptr<SlamRegistry>> Create(
      std::unique_ptr<storage::SlamStore> store, const SlamRegistryOptions& options = {});
  ~SlamRegistry();  // Shutdown()
  SlamRegistry(const SlamRegistry&) = delete;
  SlamRegistry& operator=(const SlamRegistry&) = delete;

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

  // Checkpoints every resident session with unsaved work; returns the first error.
  absl::Status CheckpointAll();
  // Rejects new messages and streams (UNAVAILABLE), lets the queues drain, checkpoints every
  // resident session and stops the workers. Idempotent; the destructor calls it.
  absl::Status Shutdown();

  const SlamRegistryOptions& options() const { return options_; }

  // Sees every answer to a processed scan or frame (not rejections), on the session's worker
  // thread just before the stream's sink: the metrics' per-session counts and latencies (metrics.h).
  // Null (the default) = none. Safe to set and clear while sessions run.
  using UpdateObserver =
      std::function<void(const std::string& session_id, const v1::SlamUpdate& update)>;
  void SetUpdateObserver(UpdateObserver observer);
  // Where robots reach this server, for the leases (SlamRegistryOptions::lease), once known.
  void set_lease_address(const std::string& address) { leases_.set_address(address); }

 private:
  SlamRegistry(std::unique_ptr<storage::SlamStore> store, const SlamRegistryOptions& options);

  absl::StatusOr<std::shared_ptr<Session>> FindResident(const std::string& id);
  // The points of the map session a localization session localizes on: NOT_FOUND (unknown),
  // FAILED_PRECONDITION (a visual session, still open, a localization session, no scans kept).
  absl::StatusOr<std::shared_ptr<const laser_slam::PointCloud>> LoadLocalizationMap(
      const std::string& map_session_id);
  // A session to read from: the resident one, or one built from its checkpoint (not made
  // resident); `visual_refusal` for a stored visual session (its engine is not built to read it).
  absl::StatusOr<std::shared_ptr<Session>> SessionToRead(const std::string& session_id,
                                                         const absl::Status& visual_refusal);
  // A session's engine built from its stored record (not made resident).
  absl::StatusOr<std::unique_ptr<SessionEngine>> EngineOf(const storage::SlamSessionRecord& record);
  // Checks the request's common fields (robot id, name) as CreateSession does.
  static absl::Status CheckNewSessionRequest(const std::string& robot_id, const std::string& name);
  // Stores a new session around `engine` (id, limits) and makes it resident unless `close`.
  absl::StatusOr<v1::Session> StoreNewSession(const std::string& robot_id,
                                              const std::string& name, std::string config_bytes,
                                              std::unique_ptr<SessionEngine> engine, bool close);
  // Builds a session (engine from the checkpoint + stored trajectory) from its stored record.
  absl::StatusOr<std::shared_ptr<Session>> LoadSession(const storage::SlamSessionRecord& record);
  // `loaded` (optional) tells whether the session was loaded from the store by this call.
  absl::StatusOr<std::shared_ptr<Session>> ResidentOrLoad(const std::string& id,
                                                          bool* loaded = nullptr);
  // CloseSession's work, with load_mutex_ held.
  absl::Status CloseLocked(const std::string& session_id);

  absl::Status Submit(const std::shared_ptr<Session>& session, uint64_t epoch,
                      const v1::SensorData& data);
  void Schedule(std::shared_ptr<Session> session);
  void WorkerLoop();
  void RunSession(const std::shared_ptr<Session>& session);
  void Process(Session& session, QueuedMessage& message, const SlamUpdateSink& sink);
  // Processes one admitted message on the session's engine and counts it (engine_mu held, or the
  // session not shared yet); the update without its sequence, or the engine's error.
  absl::StatusOr<std::optional<v1::SlamUpdate>> Apply(Session& session, EngineInput& input,
                                                     bool is_scan, double stamp,
                                                     int64_t journal_seq, size_t journal_bytes,
                                                     double queue_ms);
  // Replays the journal after the session's checkpoint (LoadSession).
  absl::Status ReplayJournal(Session& session);
  void TimerLoop();
  // Renews the leases of the resident sessions every ttl/3; drops those another server took.
  void LeaseLoop();
  // Removes a session whose lease another server holds: no checkpoint, its stream is told.
  void DropLost(const std::string& session_id, const absl::Status& moved);
  static void WaitIdle(Session& session);
  absl::Status Checkpoint(Session& session, bool close);
  void MaybeCheckpoint(Session& session);
  v1::Session Describe(const storage::SlamSessionRecord& record, Session* resident);

  const SlamRegistryOptions options_;
  std::unique_ptr<storage::SlamStore> store_;
  std::atomic<bool> shutting_down_{false};

  std::mutex observer_mutex_;  // guards observer_ (copied out per answer, called unlocked)
  std::shared_ptr<const UpdateObserver> observer_;
  std::mutex load_mutex_;  // serializes loading/creating/closing sessions (not the hot path)
  std::mutex mutex_;       // guards sessions_ (the map, not the sessions)
  std::map<std::string, std::shared_ptr<Session>> sessions_;  // resident (open) sessions

  std::mutex pool_mutex_;  // guards run_queue_ and stop_workers_
  std::condition_variable pool_cv_;
  std::deque<std::shared_ptr<Session>> run_queue_;  // sessions with work, FIFO
  bool stop_workers_ = false;
  std::vector<std::thread> workers_;

  std::mutex timer_mutex_;
  std::condition_variable timer_cv_;
  bool stop_timer_ = false;
  std::thread timer_;

  SessionLeases leases_;
  std::unique_ptr<SlamJournal> journal_;  // null when options_.journal is off
  std::thread lease_thread_;  // with timer_mutex_/timer_cv_/stop_timer_ for stopping

  std::mutex shutdown_mutex_;
  bool shut_down_ = false;
};

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_SLAM_SLAM_REGISTRY_H_
