#ifndef WAYMARK_SERVER_SERVICE_SLAM_SLAM_JOURNAL_H_
#define WAYMARK_SERVER_SERVICE_SLAM_SLAM_JOURNAL_H_

// The write-ahead journal of the SLAM sessions (issue 21): every message a session accepts is
// stored before the session processes it, so that what the server answered survives a crash
// (SIGKILL, OOM kill, power cut of the process; not of the machine: SQLite's WAL at
// synchronous=NORMAL syncs at its own checkpoints). A resumed session replays the journal after
// its last checkpoint (slam_registry.h).
//
// One writer thread for all sessions: whatever was appended while the previous batch was being
// written goes into the next one, in one transaction (group commit), so the cost per message
// falls as the load rises and a lone message waits for one transaction only. A batch that fails
// is retried (a busy or briefly unreachable database); after `attempts` failures its messages are
// answered with the error instead of being processed.

#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "absl/status/status.h"
#include "server/service/slam/folder.h"
#include "storage/slam_store.h"

namespace waymark::service {

struct SlamJournalOptions {
  int attempts = 3;                         // writes of a failing batch before giving up
  double retry_seconds = 0.05;              // first wait between attempts; doubles
  size_t max_batch_bytes = size_t{32} << 20;  // a larger backlog is written in several batches
};

struct SlamJournalStats {
  uint64_t batches = 0;
  uint64_t messages = 0;
  uint64_t bytes = 0;
  uint64_t failed_batches = 0;
  double write_ms = 0;  // total time in AppendJournal
};

class SlamJournal {
 public:
  // `lease_owner` is asked per batch (leases may be off: empty). The store must outlive this.
  SlamJournal(storage::SlamStore* store, std::function<std::string()> lease_owner,
              SlamJournalOptions options = {});
  ~SlamJournal();  // Stop()
  SlamJournal(const SlamJournal&) = delete;
  SlamJournal& operator=(const SlamJournal&) = delete;

  // Queues one accepted message; returns its ticket for WaitStored. Tickets increase in call
  // order, and batches are written in ticket order: call it in a session's acceptance order.
  uint64_t Append(storage::SlamJournalEntry entry);
  // Blocks until the message is in the database: OK, or why it could not be stored (then it
  // never will be). Ticket 0 (nothing appended) is OK at once.
  absl::Status WaitStored(uint64_t ticket);
  // Writes what is queued, then stops the writer; later Appends are refused (WaitStored answers
  // UNAVAILABLE). Idempotent.
  void Stop();

  SlamJournalStats stats() const;

 private:
  void WriterLoop();

  storage::SlamStore* const store_;
  const std::function<std::string()> lease_owner_;
  const SlamJournalOptions options_;

  mutable std::mutex mu_;
  std::condition_variable work_cv_;    // the writer: something queued, or stopping
  std::condition_variable stored_cv_;  // waiters: a batch is done
  std::deque<std::pair<uint64_t, storage::SlamJournalEntry>> queue_;
  uint64_t last_ticket_ = 0;
  uint64_t done_through_ = 0;  // every ticket up to this one is written or failed
  std::map<uint64_t, std::pair<uint64_t, absl::Status>> failed_;  // first -> (last, why)
  bool stopping_ = false;
  SlamJournalStats stats_;
  std::thread writer_;
};

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_SLAM_SLAM_JOURNAL_H_
