#include "server/service/idle_stream_reaper.h"

#include <grpc/grpc.h>
#include <spdlog/spdlog.h>

#include <algorithm>

namespace waymark::service {

IdleStreamReaper::IdleStreamReaper(double idle_seconds) : idle_seconds_(idle_seconds) {
  if (idle_seconds_ > 0) thread_ = std::thread([this] { Loop(); });
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
    grpc::ServerContextBase* context, AtShutdown at_shutdown) {
  std::unique_ptr<Watch> watch(new Watch(this, context));
  std::lock_guard<std::mutex> lock(mutex_);
  watched_[watch.get()] = Entry{Clock::now(), false, at_shutdown};
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
  // Under the lock: the watch (and so its call) cannot end while it is being cancelled. A
  // server-side cancel with a status sends that status to the client (TryCancel would send
  // CANCELLED, which says nothing of why).
  grpc_call_cancel_with_status(watch->context_->c_call(),
                               static_cast<grpc_status_code>(end_code_), end_message_.c_str(),
                               nullptr);
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
  const auto limit = std::chrono::duration_cast<Clock::duration>(
      std::chrono::duration<double>(idle_seconds_));
  // Checking four times per limit ends an idle stream within 1.25 limits.
  const auto period = std::max<Clock::duration>(limit / 4, std::chrono::milliseconds(50));
  std::unique_lock<std::mutex> lock(mutex_);
  while (!stopping_) {
    wake_.wait_for(lock, period, [this] { return stopping_; });
    const Clock::time_point now = Clock::now();
    for (auto& [watch, entry] : watched_) {
      if (entry.reaped || now - entry.last_activity < limit) continue;
      entry.reaped = true;
      spdlog::info("stream from {} sent nothing for {:.0f} s: ending it (--stream-idle-seconds)",
                   watch->context_->peer(), idle_seconds_);
      // Under the lock: the watch (and so its call) cannot end while it is being cancelled.
      watch->context_->TryCancel();
    }
  }
}

}  // namespace waymark::service
