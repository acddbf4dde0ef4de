#include "server/service/slam/slam_journal.h"

#include <spdlog/spdlog.h>

#include <chrono>
#include <utility>

#include "absl/strings/str_cat.h"
#include "server/common/stopwatch.h"

namespace waymark::service {

namespace {
// Failed ranges kept for WaitStored; a waiter asks within moments of the failure, so a few
// hundred batches back is plenty.
constexpr size_t kMaxFailedRanges = 256;
}  // namespace

SlamJournal::SlamJournal(storage::SlamStore* store, std::function<std::string()> lease_owner,
                         SlamJournalOptions options)
    : store_(store), lease_owner_(std::move(lease_owner)), options_(options) {
  writer_ = std::thread([this] { WriterLoop(); });
}

SlamJournal::~SlamJournal() { Stop(); }

uint64_t SlamJournal::Append(storage::SlamJournalEntry entry) {
  std::lock_guard<std::mutex> lock(mu_);
  const uint64_t ticket = ++last_ticket_;
  if (stopping_) {
    // WaitStored finds it in failed_ before it waits for the (stopped) writer.
    failed_[ticket] = {ticket, absl::UnavailableError("the SLAM journal is stopped")};
    return ticket;
  }
  queue_.emplace_back(ticket, std::move(entry));
  work_cv_.notify_one();
  return ticket;
}

absl::Status SlamJournal::WaitStored(uint64_t ticket) {
  if (ticket == 0) return absl::OkStatus();
  std::unique_lock<std::mutex> lock(mu_);
  auto failure = [&]() -> const absl::Status* {
    auto it = failed_.upper_bound(ticket);
    if (it == failed_.begin()) return nullptr;
    --it;
    return ticket <= it->second.first ? &it->second.second : nullptr;
  };
  stored_cv_.wait(lock, [&] { return done_through_ >= ticket || failure() != nullptr; });
  const absl::Status* failed = failure();
  return failed != nullptr ? *failed : absl::OkStatus();
}

void SlamJournal::Stop() {
  {
    std::lock_guard<std::mutex> lock(mu_);
    if (stopping_ && !writer_.joinable()) return;
    stopping_ = true;
  }
  work_cv_.notify_all();
  if (writer_.joinable()) writer_.join();
}

SlamJournalStats SlamJournal::stats() const {
  std::lock_guard<std::mutex> lock(mu_);
  return stats_;
}

void SlamJournal::WriterLoop() {
  while (true) {
    std::vector<storage::SlamJournalEntry> batch;
    uint64_t first = 0, last = 0;
    size_t bytes = 0;
    {
      std::unique_lock<std::mutex> lock(mu_);
      work_cv_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
      if (queue_.empty()) return;  // stopping, and everything queued is written
      first = queue_.front().first;
      while (!queue_.empty() && (batch.empty() || bytes < options_.max_batch_bytes)) {
        bytes += queue_.front().second.message.size();
        last = queue_.front().first;
        batch.push_back(std::move(queue_.front().second));
        queue_.pop_front();
      }
    }
    absl::Status status;
    double retry = options_.retry_seconds;
    const auto started = std::chrono::steady_clock::now();
    for (int attempt = 1; attempt <= options_.attempts; ++attempt) {
      status = store_->AppendJournal(batch, lease_owner_ ? lease_owner_() : std::string());
      // A seq already stored or a refused entry will not change on a retry.
      if (status.ok() || absl::IsAlreadyExists(status) || absl::IsInvalidArgument(status)) break;
      if (attempt < options_.attempts) {
        spdlog::warn("SLAM journal: writing {} messages failed (attempt {} of {}): {}",
                     batch.size(), attempt, options_.attempts, status.ToString());
        std::this_thread::sleep_for(std::chrono::duration<double>(retry));
        retry *= 2;
      }
    }
    const double write_ms = MsSince(started);
    std::lock_guard<std::mutex> lock(mu_);
    ++stats_.batches;
    stats_.messages += batch.size();
    stats_.bytes += bytes;
    stats_.write_ms += write_ms;
    if (!status.ok()) {
      ++stats_.failed_batches;
      spdlog::error("SLAM journal: {} accepted messages could not be stored and are refused: {}",
                    batch.size(), status.ToString());
      failed_[first] = {last, absl::Status(status.code(),
                                           absl::StrCat("the message could not be stored (",
                                                        status.message(), ")"))};
      while (failed_.size() > kMaxFailedRanges) failed_.erase(failed_.begin());
    }
    done_through_ = last;
    stored_cv_.notify_all();
  }
}

}  // namespace waymark::service
