#ifndef WAYMARK_SERVER_SERVICE_SLAM_SESSION_SCHEDULER_H_
#define WAYMARK_SERVER_SERVICE_SLAM_SESSION_SCHEDULER_H_

// The threads of SlamRegistry (slam_registry.h): a fixed pool of workers that runs the sessions'
// queues, and the periodic threads (idle checkpoints, lease renewal).
//
// Every session is processed in order on its own strand: at most one worker runs a session at a
// time (SlamSession::scheduled), and a worker takes at most `max_batch` messages of one session
// before it serves the next session that has work (round robin, so one fast robot cannot starve
// the others).

#include <chrono>
#include <condition_variable>
#include <deque>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <vector>

#include "server/service/slam/folder.h"
#include "server/service/slam/slam_session.h"

namespace waymark::service {

class SessionScheduler {
 public:
  // Processes one message popped from the session's queue and answers it through `sink` (the
  // stream's sink when the message was popped), on a worker thread.
  using ProcessFn =
      std::function<void(SlamSession& session, QueuedMessage& message, const SlamUpdateSink& sink)>;

  // Starts `workers` worker threads (at least one).
  SessionScheduler(int workers, int max_batch, ProcessFn process);
  ~SessionScheduler();  // StopTimers(), StopWorkers()
  SessionScheduler(const SessionScheduler&) = delete;
  SessionScheduler& operator=(const SessionScheduler&) = delete;

  // Puts a session that has work (its `scheduled` just set) at the back of the run queue. The run
  // queue holds a shared_ptr: the session lives until its messages are processed.
  void Schedule(std::shared_ptr<SlamSession> session);
  // Runs `tick` every `period` on a thread of its own until StopTimers. Called by the owner
  // before it calls StopTimers, from one thread.
  void Every(std::chrono::duration<double> period, std::function<void()> tick);
  // Stops and joins the periodic threads (a tick under way finishes first). Idempotent.
  void StopTimers();
  // Lets the workers finish the run queue, then stops and joins them. Idempotent.
  void StopWorkers();

 private:
  void WorkerLoop();
  void RunSession(const std::shared_ptr<SlamSession>& session);

  const int max_batch_;
  const ProcessFn process_;

  std::mutex pool_mutex_;  // guards run_queue_ and stop_workers_
  std::condition_variable pool_cv_;
  std::deque<std::shared_ptr<SlamSession>> run_queue_;  // sessions with work, FIFO
  bool stop_workers_ = false;
  std::vector<std::thread> workers_;

  std::mutex timer_mutex_;  // guards stop_timers_
  std::condition_variable timer_cv_;
  bool stop_timers_ = false;
  std::vector<std::thread> timers_;
};

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_SLAM_SESSION_SCHEDULER_H_
