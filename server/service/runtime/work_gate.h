#ifndef WAYMARK_SERVER_SERVICE_RUNTIME_WORK_GATE_H_
#define WAYMARK_SERVER_SERVICE_RUNTIME_WORK_GATE_H_

// Bounds how many requests do an expensive step at once, and how many may wait for a turn.
//
// The crossing registry puts feature extraction behind one: a SIFT scale space of a working-size
// image takes about 10 MB, and gRPC gives every call its own thread, so an overloaded server
// used to run one extraction per waiting robot at once (50 robots recognizing at 1 Hz on 2 cores
// grew the server from 90 to 650 MB) without answering any sooner: the CPU was the limit. With the
// gate at most `max_running` extractions share the CPU, the others wait their turn holding only
// their encoded image, and once `max_waiting` wait the next caller is told at once that the server
// is overloaded (RESOURCE_EXHAUSTED, the documented answer) instead of joining a queue whose wait
// grows without bound.

#include <string>

#include "absl/base/thread_annotations.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"
#include "absl/synchronization/mutex.h"
#include "server/service/runtime/folder.h"

namespace waymark::service {

class WorkGate {
 public:
  // A turn; the next caller may run once it is destroyed.
  class Turn {
   public:
    Turn(Turn&& other) noexcept;
    Turn& operator=(Turn&&) = delete;
    Turn(const Turn&) = delete;
    Turn& operator=(const Turn&) = delete;
    ~Turn();

   private:
    friend class WorkGate;
    explicit Turn(WorkGate* gate) : gate_(gate) {}
    WorkGate* gate_;  // null once moved from
  };

  // `max_running` >= 1; `max_waiting` >= 0.
  WorkGate(int max_running, int max_waiting);
  WorkGate(const WorkGate&) = delete;
  WorkGate& operator=(const WorkGate&) = delete;

  // Waits for a turn, or RESOURCE_EXHAUSTED naming `what` when max_waiting callers already wait.
  // The gate must outlive its turns.
  absl::StatusOr<Turn> Enter(absl::string_view what);

  int max_running() const { return max_running_; }
  int max_waiting() const { return max_waiting_; }
  int running() const;
  int waiting() const;

 private:
  bool HasRoomLocked() const ABSL_EXCLUSIVE_LOCKS_REQUIRED(mutex_);
  void Leave();

  const int max_running_;
  const int max_waiting_;
  mutable absl::Mutex mutex_;
  int running_ ABSL_GUARDED_BY(mutex_) = 0;
  int waiting_ ABSL_GUARDED_BY(mutex_) = 0;
};

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_RUNTIME_WORK_GATE_H_
