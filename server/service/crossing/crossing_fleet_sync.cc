#include "server/service/crossing/crossing_fleet_sync.h"

#include <spdlog/spdlog.h>

#include <chrono>
#include <utility>

namespace waymark::service {

std::unique_ptr<CrossingFleetSync> CrossingFleetSync::Start(CrossingRegistry* registry,
                                                            Options options) {
  if (!registry->shared()) return nullptr;
  return std::unique_ptr<CrossingFleetSync>(new CrossingFleetSync(registry, options));
}

CrossingFleetSync::CrossingFleetSync(CrossingRegistry* registry, Options options)
    : registry_(registry), options_(options), thread_([this] { Loop(); }) {}

CrossingFleetSync::~CrossingFleetSync() {
  stopping_ = true;
  thread_.join();
}

void CrossingFleetSync::Loop() {
  using Clock = std::chrono::steady_clock;
  std::unique_ptr<storage::ChangeFeed> feed;
  bool due = true;  // at start and after the feed was lost: changes may have been missed
  auto last_sync = Clock::now();
  while (!stopping_) {
    if (feed == nullptr) {
      absl::StatusOr<std::unique_ptr<storage::ChangeFeed>> opened = registry_->WatchChanges();
      if (opened.ok()) {
        feed = *std::move(opened);
      } else if (std::string error = opened.status().ToString(); error != last_error_) {
        spdlog::warn("not hearing other servers' changes ({}); syncing every {} ms", error,
                     options_.period_ms);
        last_error_ = error;
      }
    }
    if (feed != nullptr) {
      absl::StatusOr<bool> changed = feed->Wait(options_.poll_ms);
      if (!changed.ok()) {
        feed.reset();
        due = true;
      } else {
        due = due || *changed;
      }
    } else {
      std::this_thread::sleep_for(std::chrono::milliseconds(options_.poll_ms));
    }
    const auto now = Clock::now();
    if (!due && now - last_sync < std::chrono::milliseconds(options_.period_ms)) continue;
    const absl::Status synced = registry_->Sync();
    ++syncs_;
    due = false;
    // A failed sync (the database unreachable) is tried again after a second, not at once.
    last_sync = synced.ok() ? now
                            : now - std::chrono::milliseconds(options_.period_ms) +
                                  std::chrono::seconds(1);
    if (!synced.ok() && synced.ToString() != last_error_) {
      spdlog::warn("syncing with the other servers failed: {}", synced.ToString());
      last_error_ = synced.ToString();
    } else if (synced.ok()) {
      last_error_.clear();
    }
  }
}

}  // namespace waymark::service
