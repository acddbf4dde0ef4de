#ifndef WAYMARK_TESTS_SERVICE_FAULTY_SLAM_STORE_H_
#define WAYMARK_TESTS_SERVICE_FAULTY_SLAM_STORE_H_

// A SlamStore that passes every call to a real one, except that its journal writes can be held
// (to see what piles up behind a write) or made to fail (a database that cannot be written).

#include <condition_variable>
#include <memory>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "storage/slam_store.h"

namespace waymark::service {

class FaultySlamStore final : public storage::SlamStore {
 public:
  explicit FaultySlamStore(std::unique_ptr<storage::SlamStore> real) : real_(std::move(real)) {}

  // The next `count` AppendJournal calls fail with `status` (count < 0: all of them).
  void FailJournal(int count, absl::Status status) {
    std::lock_guard<std::mutex> lock(mu_);
    failures_left_ = count;
    failure_ = std::move(status);
  }
  // AppendJournal waits at its start until Release(); WaitHeld() waits until a call is waiting.
  void Hold() {
    std::lock_guard<std::mutex> lock(mu_);
    held_ = true;
  }
  void WaitHeld() {
    std::unique_lock<std::mutex> lock(mu_);
    cv_.wait(lock, [this] { return waiting_ > 0; });
  }
  void Release() {
    std::lock_guard<std::mutex> lock(mu_);
    held_ = false;
    cv_.notify_all();
  }
  // The sizes of the batches AppendJournal was called with, failed ones included.
  std::vector<size_t> batches() const {
    std::lock_guard<std::mutex> lock(mu_);
    return batches_;
  }

  absl::Status AppendJournal(const std::vector<storage::SlamJournalEntry>& entries,
                             const std::string& lease_owner) override {
    {
      std::unique_lock<std::mutex> lock(mu_);
      ++waiting_;
      cv_.notify_all();
      cv_.wait(lock, [this] { return !held_; });
      --waiting_;
      batches_.push_back(entries.size());
      if (failures_left_ != 0) {
        if (failures_left_ > 0) --failures_left_;
        return failure_;
      }
    }
    return real_->AppendJournal(entries, lease_owner);
  }

  absl::StatusOr<std::vector<storage::SlamJournalEntry>> LoadJournal(
      const std::string& id) override {
    return real_->LoadJournal(id);
  }
  absl::StatusOr<storage::SlamSessionRecord> CreateSession(
      const storage::SlamSessionRecord& session) override {
    return real_->CreateSession(session);
  }
  absl::StatusOr<storage::SlamSessionRecord> GetSession(const std::string& id) override {
    return real_->GetSession(id);
  }
  absl::StatusOr<std::vector<storage::SlamSessionRecord>> ListSessions(
      const std::string& robot_id) override {
    return real_->ListSessions(robot_id);
  }
  absl::StatusOr<int64_t> CountSessions(storage::SlamSessionState state) override {
    return real_->CountSessions(state);
  }
  absl::Status WriteCheckpoint(const std::string& id,
                               const storage::SlamCheckpoint& checkpoint) override {
    return real_->WriteCheckpoint(id, checkpoint);
  }
  absl::Status CloseSession(const std::string& id,
                            const storage::SlamCheckpoint& checkpoint) override {
    return real_->CloseSession(id, checkpoint);
  }
  absl::StatusOr<std::vector<storage::TrajectoryPoseRecord>> LoadTrajectory(
      const std::string& id) override {
    return real_->LoadTrajectory(id);
  }
  absl::StatusOr<storage::SlamLease> AcquireLease(const std::string& id, const std::string& owner,
                                                  const std::string& address,
                                                  double ttl_seconds) override {
    return real_->AcquireLease(id, owner, address, ttl_seconds);
  }
  absl::Status ReleaseLease(const std::string& id, const std::string& owner) override {
    return real_->ReleaseLease(id, owner);
  }
  absl::StatusOr<storage::SlamSessionRecord> DeleteSession(const std::string& id) override {
    return real_->DeleteSession(id);
  }

 private:
  std::unique_ptr<storage::SlamStore> real_;
  mutable std::mutex mu_;
  std::condition_variable cv_;
  int failures_left_ = 0;
  absl::Status failure_;
  bool held_ = false;
  int waiting_ = 0;
  std::vector<size_t> batches_;
};

}  // namespace waymark::service

#endif  // WAYMARK_TESTS_SERVICE_FAULTY_SLAM_STORE_H_
