#ifndef WAYMARK_TESTS_SERVICE_SLAM_ANSWERS_H_
#define WAYMARK_TESTS_SERVICE_SLAM_ANSWERS_H_

// Collects the SlamUpdates a registry stream answers. The sink is called on a worker thread, so
// both sides take the lock; Get() returns a copy the test can inspect while the stream goes on.

#include <mutex>
#include <vector>

#include "server/service/slam/slam_registry.h"
#include "waymark/v1/slam.pb.h"

namespace waymark::service {

class Answers {
 public:
  SlamUpdateSink Sink() {
    return [this](const v1::SlamUpdate& update) {
      std::lock_guard<std::mutex> lock(mutex_);
      updates_.push_back(update);
    };
  }
  std::vector<v1::SlamUpdate> Get() {
    std::lock_guard<std::mutex> lock(mutex_);
    return updates_;
  }

 private:
  std::mutex mutex_;
  std::vector<v1::SlamUpdate> updates_;
};

}  // namespace waymark::service

#endif  // WAYMARK_TESTS_SERVICE_SLAM_ANSWERS_H_
