#ifndef WAYMARK_SERVER_SERVICE_SLAM_SLAM_STREAM_H_
#define WAYMARK_SERVER_SERVICE_SLAM_SLAM_STREAM_H_

// One client stream attached to a SLAM session: what SlamRegistry::OpenStream returns
// (slam_registry.h). Its messages are admitted and answered by SessionStreams
// (session_streams.h).

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <utility>

#include "absl/status/status.h"
#include "server/service/slam/folder.h"
#include "waymark/v1/slam.pb.h"

namespace waymark::service {

struct SlamSession;
class SessionStreams;

// Receives the answers of one stream, on a worker thread, one call at a time, in message order.
using SlamUpdateSink = std::function<void(const v1::SlamUpdate& update)>;

// Sees every answer to a processed scan or frame (not rejections), on the session's worker
// thread just before the stream's sink (SlamRegistry::SetUpdateObserver).
using SlamUpdateObserver =
    std::function<void(const std::string& session_id, const v1::SlamUpdate& update)>;

// Sees every message its session's engine admitted, on the stream's thread, before it is queued
// (it may still be refused for its order or a full queue): the live view keeps the latest scans
// there, to draw each beside the pose its answer carries (server/service/live/).
using SlamInputObserver =
    std::function<void(const std::string& session_id, const v1::SensorData& data)>;

// Sees a session leave this server's memory: its state and engine were just destroyed, after it
// closed, was deleted, was taken over by another server, or was rebuilt from the store only to be
// read (session_memory.h). Runs on the thread that let the session go (a close or delete call,
// a stream ending, a worker, a reader); what was kept for the session can go.
using SlamReleasedObserver = std::function<void(const std::string& session_id)>;

// One watcher of the sessions (SlamRegistry::AddObserver); any part may be null. All are
// called without any of the registry's locks held and must return quickly: they run on the
// threads that serve the robots.
struct SlamObserver {
  SlamUpdateObserver on_update;
  SlamInputObserver on_input;
  SlamReleasedObserver on_released;
};

// Not thread-safe: one thread (the stream's reader) calls Submit and Close. Must not outlive the
// registry.
class SlamStream {
 public:
  ~SlamStream();  // Close()
  SlamStream(const SlamStream&) = delete;
  SlamStream& operator=(const SlamStream&) = delete;

  const std::string& session_id() const;
  // What the session held when this stream attached (the API's StreamStart): loaded from its
  // checkpoint for this stream or already in memory, scans processed and the last one's stamp.
  const v1::StreamStart& start() const { return start_; }
  // OK: the message is queued and, if it is a scan, will be answered through the sink.
  // Otherwise the message was rejected (see the admission rules in slam_registry.h) and the
  // status says why.
  absl::Status Submit(const v1::SensorData& data);
  // Ends the stream's input without waiting: Submit is refused from now on, and another
  // stream's OpenStream takes the session over as soon as the messages this one accepted are
  // processed and answered (through this stream's sink). Idempotent.
  void StopAccepting();
  // StopAccepting, then waits until every accepted message has been processed and answered,
  // then detaches the sink (unless another stream has taken the session over). Idempotent.
  void Close();

 private:
  friend class SessionStreams;
  SlamStream(SessionStreams* streams, std::shared_ptr<SlamSession> session, uint64_t epoch,
             v1::StreamStart start)
      : streams_(streams), session_(std::move(session)), epoch_(epoch),
        start_(std::move(start)) {}
  SessionStreams* streams_;
  std::shared_ptr<SlamSession> session_;
  const uint64_t epoch_;  // which of the session's streams this is (SlamSession::stream_epoch)
  v1::StreamStart start_;
  bool stopped_ = false;
  bool closed_ = false;
};

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_SLAM_SLAM_STREAM_H_
