#include "server/service/runtime/memory_trimmer.h"

#include <malloc.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>

#include "server/common/process_memory.h"

namespace waymark::service {

MemoryTrimmer::MemoryTrimmer(MemoryTrimmerOptions options) : options_(options) {
  if (options_.period_seconds > 0) thread_ = std::thread([this] { Loop(); });
}

MemoryTrimmer::~MemoryTrimmer() {
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stopping_ = true;
  }
  wake_.notify_all();
  if (thread_.joinable()) thread_.join();
}

double MemoryTrimmer::CheckOnce() {
  const double resident = ResidentMegabytes();
  if (resident < 0) return resident;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (baseline_mb_ < 0 || resident < baseline_mb_) {
      baseline_mb_ = resident;
      return resident;
    }
    if (resident - baseline_mb_ <= options_.growth_mb) return resident;
  }
  return Trim(resident);
}

void MemoryTrimmer::TrimSoon() {
  if (!thread_.joinable()) {
    Trim(ResidentMegabytes());
    return;
  }
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (trim_requested_) return;  // the coming trim serves this request too
    trim_requested_ = true;
  }
  wake_.notify_all();
}

double MemoryTrimmer::Trim(double resident_before) {
  malloc_trim(0);
  const double after = ResidentMegabytes();
  {
    std::lock_guard<std::mutex> lock(mutex_);
    if (after >= 0) baseline_mb_ = after;
    ++trims_;
  }
  spdlog::debug("memory: resident {:.0f} MB, {:.0f} MB after returning free heap", resident_before,
                after);
  return after;
}

int MemoryTrimmer::trims() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return trims_;
}

void MemoryTrimmer::Loop() {
  const auto period = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(options_.period_seconds));
  const auto settle = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(std::max(0.0, options_.settle_seconds)));
  std::unique_lock<std::mutex> lock(mutex_);
  while (!stopping_) {
    wake_.wait_for(lock, period, [this] { return stopping_ || trim_requested_; });
    if (stopping_) break;
    if (trim_requested_) {
      // Let the rest of a burst of frees happen first; their requests join this one.
      wake_.wait_for(lock, settle, [this] { return stopping_; });
      if (stopping_) break;
      trim_requested_ = false;
      lock.unlock();
      Trim(ResidentMegabytes());
    } else {
      lock.unlock();
      CheckOnce();
    }
    lock.lock();
  }
}

}  // namespace waymark::service
