#ifndef WAYMARK_SERVER_SERVICE_SLAM_SLAM_SESSION_H_
#define WAYMARK_SERVER_SERVICE_SLAM_SLAM_SESSION_H_

// One SLAM session in memory and the messages waiting for it: the state that SlamRegistry's parts
// (slam_registry.h) share, and the rules they all apply to it: processing one message, waiting for
// the queue, the errors that name a session.

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "server/service/slam/folder.h"
#include "server/service/slam/session_engine.h"
#include "server/service/slam/slam_stream.h"
#include "waymark/v1/slam.pb.h"

namespace waymark::service {

using SessionClock = std::chrono::steady_clock;

// One accepted message, converted to engine types at admission.
struct QueuedMessage {
  uint64_t sequence = 0;
  bool is_scan = false;  // answered: a scan or a frame
  double stamp = 0;
  size_t bytes = 0;
  std::unique_ptr<EngineInput> input;
  SessionClock::time_point accepted;
  int64_t journal_seq = 0;     // the session's journal seq (1, 2, 3, ...)
  uint64_t journal_ticket = 0;  // SlamJournal::WaitStored before processing; 0 = no journal
  size_t journal_bytes = 0;     // the stored message's size
};

// A session resident on this server (open, in the session table), or built from its checkpoint to
// be read or closed.
struct SlamSession {
  // Fixed at creation or load.
  std::string id;
  std::string robot_id;
  std::string name;
  std::string kind;  // "laser" or "visual"
  double created_at = 0;

  // Admission and queue. Lock order: the session table's mutex -> mu; never mu and engine_mu
  // together.
  std::mutex mu;
  std::condition_variable idle_cv;  // queue empty and nothing in flight
  std::deque<QueuedMessage> queue;
  size_t queued_bytes = 0;  // decoded frames waiting (visual sessions)
  bool scheduled = false;  // on the run queue or being run by a worker
  bool in_flight = false;  // a worker holds a popped message
  bool stream_attached = false;
  // The attached stream has stopped accepting (its client half-closed, cancelled or vanished):
  // the next stream takes the session over once the queue is idle (OpenStream).
  bool stream_stopping = false;
  uint64_t stream_epoch = 0;  // counts the streams attached so far; the attached one's number
  std::function<void()> stream_cancel;  // ends the attached stream's call (OpenStream's takeover)
  bool closed = false;  // closing or closed: no stream, no message
  // Set when another server took the session's lease over: what every message is answered.
  std::optional<absl::Status> lost;
  SlamUpdateSink sink;
  std::optional<double> accepted_scan_stamp;
  std::optional<double> accepted_odometry_stamp;
  int64_t journal_last = 0;  // journal seq of the last accepted message
  uint64_t rejected = 0;
  uint64_t dropped = 0;

  // The engine and what goes with it; the strand (one worker at a time) mutates, readers and
  // checkpoints take the lock briefly.
  std::mutex engine_mu;
  std::unique_ptr<SessionEngine> engine;  // fixed once the session is built
  int64_t scans_processed = 0;
  uint64_t map_revision = 0;
  int segments = 0;
  std::optional<double> processed_scan_stamp;
  std::optional<double> processed_odometry_stamp;
  bool dirty = false;  // processed work not in the last checkpoint
  int scans_since_checkpoint = 0;
  int64_t journal_processed = 0;  // journal seq of the last processed message
  size_t journal_bytes_since_checkpoint = 0;
  SessionClock::time_point last_checkpoint = SessionClock::now();
  double updated_at = 0;
  double checkpoint_at = 0;

  // Serializes checkpoint writes; guards stored_poses and finalized.
  std::mutex checkpoint_mu;
  int64_t stored_poses = 0;  // trajectory poses already in the store
  bool finalized = false;    // closed in the store: no more checkpoints
};

// Processes one admitted message on the session's engine and counts it (engine_mu held, or the
// session not shared yet); the update without its sequence, or the engine's error. Live messages
// (SessionStreams::Process) and replayed ones (SessionPersistence) go through here alike.
absl::StatusOr<std::optional<v1::SlamUpdate>> ApplyMessage(SlamSession& session,
                                                           EngineInput& input, bool is_scan,
                                                           double stamp, int64_t journal_seq,
                                                           size_t journal_bytes, double queue_ms);

// Waits until the session's queue is empty and no worker holds one of its messages.
void WaitIdle(SlamSession& session);

// Seconds since the Unix epoch: the times the store keeps and the API shows.
double UnixNow();

// A session id (the client's, or a map session it names) in a message: valid UTF-8, escaped,
// and whole up to the 128 characters CheckSessionId allows (issue 35: server/common/quote.h).
std::string QuotedId(const std::string& id);

absl::Status SessionNotFound(const std::string& id);
absl::Status SessionClosedError(const std::string& id);
// INVALID_ARGUMENT for an empty id or one over 128 characters.
absl::Status CheckSessionId(const std::string& id);

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_SLAM_SLAM_SESSION_H_
