#ifndef WAYMARK_BENCH_ROBUSTNESS_HOSTILE_CAMPAIGN_SERVER_H_
#define WAYMARK_BENCH_ROBUSTNESS_HOSTILE_CAMPAIGN_SERVER_H_

// waymark-hostile-campaign: the real waymark-server under attack. It is watched all the time: a
// thread reads its resident memory every 100 ms (VmRSS; the peak is what the campaign pushed it
// to) and notices at once when the process is gone, so the calls in flight can be kept as the
// likely cause. After a crash it is started again on the same database file and port.

#include <sys/types.h>

#include <atomic>
#include <chrono>
#include <memory>
#include <mutex>
#include <nlohmann/json.hpp>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "absl/status/statusor.h"
#include "tests/support/server_process.h"

namespace waymark::bench::hostile {

class WatchedServer {
 public:
  // Starts waymark-server on `db` (a fresh SQLite file), with or without authentication.
  static absl::StatusOr<std::unique_ptr<WatchedServer>> Start(const std::string& db, bool auth);
  ~WatchedServer();

  const std::string& address() const { return address_; }
  const std::string& db() const { return db_; }
  // False once the process has exited (checked every 100 ms, and now).
  bool Alive();
  // Whether the process exits within `wait`.
  bool DiesWithin(std::chrono::milliseconds wait);
  // The exit code of a process that is gone (128 + signal when a signal ended it).
  std::optional<int> ExitCode();
  // The current process's log (each start has its own file).
  std::string Log() const;
  // Starts the server again on the same database and port after it died.
  absl::Status Restart();
  // SIGTERM and wait: the exit code.
  int Terminate();

  // Resident memory in MB: now, and the highest sample since the last ResetPeak().
  double RssMb();
  double PeakMb() const { return peak_mb_.load(); }
  void ResetPeak();
  // VmHWM of the current process: the kernel's own peak, in MB.
  double KernelPeakMb();

 private:
  WatchedServer(std::string db, bool auth) : db_(std::move(db)), auth_(auth) {}
  absl::Status Launch(const std::string& listen);
  // Reaps the process if it exited; whether it still runs. Needs mutex_.
  bool CheckRunningLocked();
  void Sample();  // memory and liveness, every 100 ms

  const std::string db_;
  const bool auth_;
  std::string address_;
  mutable std::mutex mutex_;  // process_ (waitpid is not thread-safe on one child)
  std::unique_ptr<testing::ServerProcess> process_;
  std::optional<int> exit_code_;
  std::atomic<bool> alive_{false};
  std::atomic<double> peak_mb_{0};
  std::atomic<bool> stop_{false};
  std::thread sampler_;
};

// PRAGMA integrity_check and foreign_key_check on a SQLite file (no server on it), and the rows
// of each table.
nlohmann::json CheckSqlite(const std::string& path);

// "key" log lines: every line at warning level or above, counted by their text after the
// timestamp (request ids and peers cut), the first few kept in full.
nlohmann::json SummarizeLog(const std::string& log);

}  // namespace waymark::bench::hostile

#endif  // WAYMARK_BENCH_ROBUSTNESS_HOSTILE_CAMPAIGN_SERVER_H_
