#ifndef WAYMARK_SERVER_SERVICE_RUNTIME_STREAM_LIMITER_H_
#define WAYMARK_SERVER_SERVICE_RUNTIME_STREAM_LIMITER_H_

// Caps the streams one robot holds open at once (SLAM sensor streams, recognition streams, bulk
// enrolls), so one misbehaving robot cannot take every request thread of a server shared by many.
// Plain C++; the services ask it when a stream starts and hold the lease until it ends.

#include <map>
#include <memory>
#include <mutex>
#include <string>

#include "absl/status/statusor.h"
#include "server/service/runtime/folder.h"

namespace waymark::service {

class StreamLimiter {
 public:
  // Held while a stream runs; releases its slot when destroyed.
  class Lease {
   public:
    ~Lease();
    Lease(const Lease&) = delete;
    Lease& operator=(const Lease&) = delete;

   private:
    friend class StreamLimiter;
    Lease(StreamLimiter* limiter, std::string robot_id)
        : limiter_(limiter), robot_id_(std::move(robot_id)) {}
    StreamLimiter* limiter_;
    std::string robot_id_;
  };

  // 0 = no limit.
  explicit StreamLimiter(int max_streams_per_robot) : max_per_robot_(max_streams_per_robot) {}

  // A slot for one more stream of `robot_id`, or RESOURCE_EXHAUSTED saying how many it holds.
  // The limiter must outlive its leases.
  absl::StatusOr<std::unique_ptr<Lease>> Acquire(const std::string& robot_id);

  int max_per_robot() const { return max_per_robot_; }
  // Streams `robot_id` holds now (for tests and metrics).
  int Open(const std::string& robot_id);

 private:
  void Release(const std::string& robot_id);

  const int max_per_robot_;
  std::mutex mutex_;
  std::map<std::string, int> open_;  // robots with at least one stream
};

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_RUNTIME_STREAM_LIMITER_H_
