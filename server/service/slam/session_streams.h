#ifndef WAYMARK_SERVER_SERVICE_SLAM_SESSION_STREAMS_H_
#define WAYMARK_SERVER_SERVICE_SLAM_SESSION_STREAMS_H_

// The streams of SLAM sessions: which stream owns a session and how a newer one takes it over,
// what a stream's message must be to be queued (the admission rules of slam_registry.h), and the
// answer each processed message gets (SessionScheduler's workers call Process).

#include <atomic>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "server/service/slam/folder.h"
#include "server/service/slam/slam_registry_options.h"
#include "server/service/slam/slam_session.h"
#include "server/service/slam/slam_stream.h"
#include "waymark/v1/slam.pb.h"

namespace waymark::service {

class SessionPersistence;
class SessionScheduler;
class SlamJournal;

class SessionStreams {
 public:
  // None is owned; all must outlive this. `journal` is null when the journal is off.
  SessionStreams(const SlamRegistryOptions& options, const std::atomic<bool>* shutting_down,
                 SlamJournal* journal, SessionScheduler* scheduler,
                 SessionPersistence* persistence)
      : options_(options), shutting_down_(shutting_down), journal_(journal),
        scheduler_(scheduler), persistence_(persistence) {}

  // Attaches a stream to a resident session (`loaded`: loaded from the store for this stream).
  // A stream already attached is taken over: it accepts nothing more (ABORTED), `cancel` of its
  // OpenStream is called, and the new stream attaches once the messages the old one accepted are
  // processed. FAILED_PRECONDITION (closed), UNAVAILABLE (the old stream's messages not answered
  // within stream_handover_wait).
  absl::StatusOr<std::unique_ptr<SlamStream>> Attach(const std::shared_ptr<SlamSession>& session,
                                                     bool loaded, SlamUpdateSink sink,
                                                     std::function<void()> cancel);
  // Admits a message of the stream `epoch` of `owner` and queues it (SlamStream::Submit).
  absl::Status Submit(const std::shared_ptr<SlamSession>& owner, uint64_t epoch,
                      const v1::SensorData& data);
  // Processes one queued message and answers it through `sink` (SessionScheduler::ProcessFn).
  void Process(SlamSession& session, QueuedMessage& message, const SlamUpdateSink& sink);

  // Null (the default) = none. Safe to set and clear while sessions run.
  void SetUpdateObserver(SlamUpdateObserver observer);
  // More watchers beside the one above (SlamRegistry::AddObserver); safe while sessions run.
  // Their on_released goes to the sessions' memory (SessionPersistence::memory()).
  uint64_t AddObserver(SlamObserver observer);
  void RemoveObserver(uint64_t id);

 private:
  const SlamRegistryOptions& options_;
  const std::atomic<bool>* const shutting_down_;
  SlamJournal* const journal_;
  SessionScheduler* const scheduler_;
  SessionPersistence* const persistence_;

  std::shared_ptr<const std::vector<std::pair<uint64_t, std::shared_ptr<const SlamObserver>>>>
  Observers();

  std::mutex observer_mutex_;  // guards observer_ (copied out per answer, called unlocked)
  std::shared_ptr<const SlamUpdateObserver> observer_;
  // Copied out per message (copy on write), called unlocked.
  using ObserverList = std::vector<std::pair<uint64_t, std::shared_ptr<const SlamObserver>>>;
  std::shared_ptr<const ObserverList> observers_ = std::make_shared<const ObserverList>();
  uint64_t next_observer_id_ = 1;
};

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_SLAM_SESSION_STREAMS_H_
