#include "server/service/slam/session_scheduler.h"

#include <utility>

namespace waymark::service {

namespace {

// Sets `stop` under `mutex`, wakes the threads waiting on `cv` and joins them.
void StopAndJoin(std::mutex& mutex, bool& stop, std::condition_variable& cv,
                 std::vector<std::thread>& threads) {
  {
    std::lock_guard<std::mutex> lock(mutex);
    stop = true;
  }
  cv.notify_all();
  for (std::thread& thread : threads) {
    if (thread.joinable()) thread.join();
  }
}

}  // namespace

SessionScheduler::SessionScheduler(int workers, int max_batch, ProcessFn process)
    : max_batch_(max_batch), process_(std::move(process)) {
  for (int i = 0; i < workers; ++i) workers_.emplace_back([this] { WorkerLoop(); });
}

SessionScheduler::~SessionScheduler() {
  StopTimers();
  StopWorkers();
}

void SessionScheduler::Schedule(std::shared_ptr<SlamSession> session) {
  {
    std::lock_guard<std::mutex> lock(pool_mutex_);
    run_queue_.push_back(std::move(session));
  }
  pool_cv_.notify_one();
}

void SessionScheduler::Every(std::chrono::duration<double> period, std::function<void()> tick) {
  timers_.emplace_back([this, period, tick = std::move(tick)] {
    std::unique_lock<std::mutex> lock(timer_mutex_);
    while (!stop_timers_) {
      timer_cv_.wait_for(lock, period, [this] { return stop_timers_; });
      if (stop_timers_) return;
      lock.unlock();
      tick();
      lock.lock();
    }
  });
}

void SessionScheduler::StopTimers() { StopAndJoin(timer_mutex_, stop_timers_, timer_cv_, timers_); }

void SessionScheduler::StopWorkers() {
  StopAndJoin(pool_mutex_, stop_workers_, pool_cv_, workers_);
}

void SessionScheduler::WorkerLoop() {
  while (true) {
    std::shared_ptr<SlamSession> session;
    {
      std::unique_lock<std::mutex> lock(pool_mutex_);
      pool_cv_.wait(lock, [this] { return stop_workers_ || !run_queue_.empty(); });
      if (run_queue_.empty()) return;  // stopping and nothing left
      session = std::move(run_queue_.front());
      run_queue_.pop_front();
    }
    RunSession(session);
  }
}

void SessionScheduler::RunSession(const std::shared_ptr<SlamSession>& session) {
  for (int i = 0; i < max_batch_; ++i) {
    QueuedMessage message;
    SlamUpdateSink sink;
    {
      std::lock_guard<std::mutex> lock(session->mu);
      if (session->queue.empty()) {
        session->scheduled = false;
        session->idle_cv.notify_all();
        return;
      }
      message = std::move(session->queue.front());
      session->queue.pop_front();
      session->queued_bytes -= message.bytes;
      session->in_flight = true;
      sink = session->sink;
    }
    process_(*session, message, sink);
    {
      std::lock_guard<std::mutex> lock(session->mu);
      session->in_flight = false;
      if (session->queue.empty()) {
        session->scheduled = false;
        session->idle_cv.notify_all();
        return;
      }
    }
  }
  Schedule(session);  // more waiting: go to the back of the line
}

}  // namespace waymark::service
