#ifndef WAYMARK_TESTS_SERVICE_BLOCKING_GATE_H_
#define WAYMARK_TESTS_SERVICE_BLOCKING_GATE_H_

// Holds a SLAM worker (SlamRegistryOptions::before_process) before each message until opened, and
// counts the messages that reached it: lets tests fill queues to an exact depth.

#include <condition_variable>
#include <mutex>

namespace waymark::service {

class BlockingGate {
 public:
  void Enter() {
    std::unique_lock<std::mutex> lock(mutex_);
    ++entered_;
    cv_.notify_all();
    cv_.wait(lock, [this] { return open_; });
  }
  void WaitEntered(int n) {
    std::unique_lock<std::mutex> lock(mutex_);
    cv_.wait(lock, [&] { return entered_ >= n; });
  }
  void Open() {
    std::lock_guard<std::mutex> lock(mutex_);
    open_ = true;
    cv_.notify_all();
  }

 private:
  std::mutex mutex_;
  std::condition_variable cv_;
  int entered_ = 0;
  bool open_ = false;
};

}  // namespace waymark::service

#endif  // WAYMARK_TESTS_SERVICE_BLOCKING_GATE_H_
