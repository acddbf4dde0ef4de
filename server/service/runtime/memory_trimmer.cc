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
  std::lock_guard<std::mutex> lock(mutex_);
  if (baseline_mb_ < 0 || resident < baseline_mb_) {
    baseline_mb_ = resident;
    return resident;
  }
  if (resident - baseline_mb_ <= options_.growth_mb) return resident;
  malloc_trim(0);
  const double after = ResidentMegabytes();
  baseline_mb_ = after;
  ++trims_;
  spdlog::debug("memory: resident {:.0f} MB, {:.0f} MB after returning free heap", resident, after);
  return after;
}

int MemoryTrimmer::trims() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return trims_;
}

void MemoryTrimmer::Loop() {
  const auto period = std::chrono::duration_cast<std::chrono::steady_clock::duration>(
      std::chrono::duration<double>(options_.period_seconds));
  std::unique_lock<std::mutex> lock(mutex_);
  while (!stopping_) {
    wake_.wait_for(lock, period, [this] { return stopping_; });
    if (stopping_) break;
    lock.unlock();
    CheckOnce();
    lock.lock();
  }
}

}  // namespace waymark::service
