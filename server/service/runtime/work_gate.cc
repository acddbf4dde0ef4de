#include "server/service/runtime/work_gate.h"

#include <algorithm>
#include <utility>

#include "absl/strings/str_cat.h"

namespace waymark::service {

WorkGate::Turn::Turn(Turn&& other) noexcept : gate_(std::exchange(other.gate_, nullptr)) {}

WorkGate::Turn::~Turn() {
  if (gate_ != nullptr) gate_->Leave();
}

WorkGate::WorkGate(int max_running, int max_waiting)
    : max_running_(std::max(1, max_running)), max_waiting_(std::max(0, max_waiting)) {}

absl::StatusOr<WorkGate::Turn> WorkGate::Enter(absl::string_view what) {
  absl::MutexLock lock(&mutex_);
  if (running_ < max_running_) {
    ++running_;
    return Turn(this);
  }
  if (waiting_ >= max_waiting_) {
    return absl::ResourceExhaustedError(absl::StrCat("server overloaded: ", running_, " ", what,
                                                     " running and ", waiting_,
                                                     " waiting; retry later"));
  }
  ++waiting_;
  mutex_.Await(absl::Condition(this, &WorkGate::HasRoomLocked));
  --waiting_;
  ++running_;
  return Turn(this);
}

bool WorkGate::HasRoomLocked() const { return running_ < max_running_; }

void WorkGate::Leave() {
  absl::MutexLock lock(&mutex_);
  --running_;
}

int WorkGate::running() const {
  absl::MutexLock lock(&mutex_);
  return running_;
}

int WorkGate::waiting() const {
  absl::MutexLock lock(&mutex_);
  return waiting_;
}

}  // namespace waymark::service
