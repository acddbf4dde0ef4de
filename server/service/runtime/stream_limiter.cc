#include "server/service/runtime/stream_limiter.h"

#include "absl/strings/str_cat.h"
#include "server/common/quote.h"

namespace waymark::service {

StreamLimiter::Lease::~Lease() { limiter_->Release(robot_id_); }

absl::StatusOr<std::unique_ptr<StreamLimiter::Lease>> StreamLimiter::Acquire(
    const std::string& robot_id) {
  std::lock_guard<std::mutex> lock(mutex_);
  int& open = open_[robot_id];
  if (max_per_robot_ > 0 && open >= max_per_robot_) {
    return absl::ResourceExhaustedError(
        absl::StrCat("robot ", QuoteClientText(robot_id), " already has ", open,
                     " streams open (the limit is ", max_per_robot_,
                     ", server option --max-streams-per-robot); end one first"));
  }
  ++open;
  return std::unique_ptr<Lease>(new Lease(this, robot_id));
}

int StreamLimiter::Open(const std::string& robot_id) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto found = open_.find(robot_id);
  return found == open_.end() ? 0 : found->second;
}

void StreamLimiter::Release(const std::string& robot_id) {
  std::lock_guard<std::mutex> lock(mutex_);
  const auto found = open_.find(robot_id);
  if (found == open_.end()) return;
  if (--found->second <= 0) open_.erase(found);
}

}  // namespace waymark::service
