#ifndef WAYMARK_SERVER_SERVICE_LIVE_LIVE_HUB_H_
#define WAYMARK_SERVER_SERVICE_LIVE_LIVE_HUB_H_

// What the robots' threads leave for the live view: per session, the latest answer and the scan
// it answered, as latest-value slots (a newer value replaces an older one that was not taken: a
// viewer sees the newest, never a backlog), and the latest crossing recognition answers.
//
// The observers (SlamRegistry::AddObserver, CrossingRegistry::SetRecognitionObserver) run on the
// threads that serve the robots: each takes this hub's one mutex for a copy into a slot and
// returns. Nothing here waits on a viewer, a socket or the live thread, so a viewer can never slow
// a robot. Memory is bounded: one answer and at most `scan_ring` scans per session (the scans a
// session admitted and has not answered yet; older ones are dropped), `max_recognitions` answers.

#include <atomic>
#include <cstdint>
#include <deque>
#include <map>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "server/service/live/folder.h"
#include "server/service/live/live_messages.h"
#include "waymark/v1/crossing.pb.h"
#include "waymark/v1/slam.pb.h"

namespace waymark::service::live {

class LiveHub {
 public:
  explicit LiveHub(size_t scan_ring = 64, size_t max_recognitions = 16)
      : scan_ring_(scan_ring), max_recognitions_(max_recognitions) {}

  // Observers (any thread).
  void OnInput(const std::string& session_id, const v1::SensorData& data);
  void OnUpdate(const std::string& session_id, const v1::SlamUpdate& update);
  void OnRecognition(const std::string& database, const v1::RecognizeResponse& response);

  // What the live thread takes from a session's slots: the answer, if a newer one came since the
  // last Take, and the scan it answered (when the session admitted one with that sequence).
  struct Latest {
    std::optional<v1::SlamUpdate> update;
    std::optional<ScanSample> scan;
  };
  Latest Take(const std::string& session_id);
  // Sessions with an answer not taken yet.
  std::vector<std::string> SessionsWithNews();
  // The recognitions since the last call, oldest first (at most max_recognitions; older ones
  // were dropped, counted in recognitions_dropped).
  struct Recognition {
    std::string database;
    v1::RecognizeResponse response;
  };
  std::vector<Recognition> TakeRecognitions();
  // A session that closed or was deleted: its slots go.
  void Forget(const std::string& session_id);
  // Keeps only these sessions' slots (the open ones); the rest go.
  void Retain(const std::vector<std::string>& open_sessions);
  // With nobody watching, the observers return at once and keep nothing (the default).
  void set_watched(bool watched) { watched_.store(watched, std::memory_order_relaxed); }

  // For the measurement in docs/live-view.md and the tests.
  size_t sessions() const;
  uint64_t recognitions_dropped() const;

 private:
  struct Slots {
    std::optional<v1::SlamUpdate> update;  // not taken yet
    std::optional<ScanSample> scan;        // the scan `update` answers
    std::deque<ScanSample> admitted;       // scans waiting for their answer, oldest first
  };

  const size_t scan_ring_;
  const size_t max_recognitions_;
  std::atomic<bool> watched_{false};
  mutable std::mutex mu_;
  std::map<std::string, Slots> sessions_;
  std::deque<Recognition> recognitions_;
  uint64_t recognitions_dropped_ = 0;
};

}  // namespace waymark::service::live

#endif  // WAYMARK_SERVER_SERVICE_LIVE_LIVE_HUB_H_
