#include "server/service/runtime/idle_stream_reaper.h"

#include <grpc/grpc.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <utility>
#include <vector>

#include "absl/strings/str_cat.h"

namespace waymark::service {

IdleStreamReaper::IdleStreamReaper(double idle_seconds, double revalidate_seconds)
    : idle_seconds_(idle_seconds), revalidate_seconds_(revalidate_seconds) {
  if (idle_seconds_ > 0 || revalidate_seconds_ > 0) thread_ = std::thread([this] { Loop(); });
}

IdleStreamReaper::~IdleStreamReaper() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

std::unique_ptr<IdleStreamReaper::Watch> IdleStreamReaper::WatchStream(
    grpc::ServerContextBase* context, AtShutdown at_shutdown, Revalidation revalidate) {
  std::unique_ptr<Watch> watch(new Watch(this, context));
  std::lock_guard<std::mutex> lock(mutex_);
  watched_[watch.get()] =
      Entry{Clock::now(), false, at_shutdown, std::move(revalidate), next_serial_++};
  // A robot reconnecting during the shutdown.
  if (ending_all_ && at_shutdown == AtShutdown::kEnd) EndLocked(watch.get());
  return watch;
}

void IdleStreamReaper::EndAll(grpc::StatusCode code, const std::string& message) {
  std::lock_guard<std::mutex> lock(mutex_);
  ending_all_ = true;
  end_code_ = code;
  end_message_ = message;
  int ended = 0;
  for (const auto& [watch, entry] : watched_) {
    if (entry.at_shutdown != AtShutdown::kEnd) continue;
    EndLocked(watch);
    ++ended;
  }
  if (ended > 0) spdlog::info("ended {} open streams: {}", ended, message);
  if (static_cast<size_t>(ended) < watched_.size()) {
    spdlog::info("{} enrollment streams may finish within the grace", watched_.size() - ended);
  }
}

void IdleStreamReaper::EndLocked(const Watch* watch) {
  EndWithStatusLocked(watch, end_code_, end_message_);
}

void IdleStreamReaper::EndWithStatusLocked(const Watch* watch, grpc::StatusCode code,
                                           const std::string& message) {
  // Under the lock: the watch (and so its call) cannot end while it is being cancelled. A
  // server-side cancel with a status sends that status to the client (TryCancel would send
  // CANCELLED, which says nothing of why).
  grpc_call_cancel_with_status(watch->context_->c_call(), static_cast<grpc_status_code>(code),
                               message.c_str(), nullptr);
}

IdleStreamReaper::Watch::~Watch() {
  std::lock_guard<std::mutex> lock(reaper_->mutex_);
  reaper_->watched_.erase(this);
}

void IdleStreamReaper::Watch::Touch() {
  std::lock_guard<std::mutex> lock(reaper_->mutex_);
  const auto found = reaper_->watched_.find(this);
  if (found != reaper_->watched_.end()) found->second.last_activity = Clock::now();
}

bool IdleStreamReaper::Watch::reaped() const {
  std::lock_guard<std::mutex> lock(reaper_->mutex_);
  const auto found = reaper_->watched_.find(this);
  return found != reaper_->watched_.end() && found->second.reaped;
}

void IdleStreamReaper::Loop() {
  const auto seconds = [](double s) {
    return std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s));
  };
  // Checking four times per idle limit ends an idle stream within 1.25 limits.
  Clock::duration period = std::chrono::hours(1);
  if (idle_seconds_ > 0) period = std::min(period, seconds(idle_seconds_) / 4);
  if (revalidate_seconds_ > 0) period = std::min(period, seconds(revalidate_seconds_));
  period = std::max<Clock::duration>(period, std::chrono::milliseconds(50));
  Clock::time_point next_revalidation = Clock::now();
  std::unique_lock<std::mutex> lock(mutex_);
  while (!stopping_) {
    wake_.wait_for(lock, period, [this] { return stopping_; });
    if (stopping_) break;
    const Clock::time_point now = Clock::now();
    if (idle_seconds_ > 0) ReapIdleLocked(now);
    if (revalidate_seconds_ > 0 && now >= next_revalidation) {
      next_revalidation = now + seconds(revalidate_seconds_);
      RevalidateUnlocked(lock);
    }
  }
}

void IdleStreamReaper::ReapIdleLocked(Clock::time_point now) {
  const auto limit = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(idle_seconds_));
  for (auto& [watch, entry] : watched_) {
    if (entry.reaped || now - entry.last_activity < limit) continue;
    entry.reaped = true;
    spdlog::info("stream from {} sent nothing for {:.0f} s: ending it (--stream-idle-seconds)",
                 watch->context_->peer(), idle_seconds_);
    // Under the lock: the watch (and so its call) cannot end while it is being cancelled.
    watch->context_->TryCancel();
  }
}

void IdleStreamReaper::RevalidateUnlocked(std::unique_lock<std::mutex>& lock) {
  struct Asked {
    const Watch* watch;
    uint64_t serial;
    Revalidation revalidate;
    absl::Status status;
  };
  std::vector<Asked> asked;
  for (const auto& [watch, entry] : watched_) {
    if (!entry.reaped && entry.revalidate) asked.push_back({watch, entry.serial, entry.revalidate});
  }
  if (asked.empty()) return;
  lock.unlock();
  for (Asked& a : asked) a.status = a.revalidate();
  lock.lock();
  for (const Asked& a : asked) {
    // Only a refusal of the token ends the stream; a database that cannot answer does not.
    if (a.status.code() != absl::StatusCode::kUnauthenticated) continue;
    // The stream may have ended while unlocked (and another been watched at the same address).
    const auto found = watched_.find(a.watch);
    if (found == watched_.end() || found->second.serial != a.serial || found->second.reaped) {
      continue;
    }
    found->second.reaped = true;
    spdlog::info("stream from {} ended: {}", a.watch->context_->peer(),
                 std::string(a.status.message()));
    EndWithStatusLocked(a.watch, grpc::StatusCode::UNAUTHENTICATED,
                        absl::StrCat(a.status.message(), " (since the stream opened)"));
  }
}

}  // namespace waymark::service
