#ifndef WAYMARK_SERVER_SERVICE_RUNTIME_MEMORY_TRIMMER_H_
#define WAYMARK_SERVER_SERVICE_RUNTIME_MEMORY_TRIMMER_H_

// Gives freed heap back to the system. glibc keeps what the request threads free in their
// arenas: after a burst of large concurrent inputs (enrollments, big scans) the server's resident
// memory stayed at the burst's peak for good, although nothing held it (issue 21: 64 MB at
// start, 929 MB at the end of a campaign with no leak found). Every `period` this checks the
// resident size and, when it grew by more than `growth_mb` since the last trim, calls
// malloc_trim, which returns the arenas' free pages.

#include <condition_variable>
#include <mutex>
#include <thread>

#include "server/service/runtime/folder.h"

namespace waymark::service {

struct MemoryTrimmerOptions {
  double period_seconds = 10;
  double growth_mb = 32;
};

class MemoryTrimmer {
 public:
  explicit MemoryTrimmer(MemoryTrimmerOptions options = {});
  ~MemoryTrimmer();
  MemoryTrimmer(const MemoryTrimmer&) = delete;
  MemoryTrimmer& operator=(const MemoryTrimmer&) = delete;

  // One check now (what the thread does every period); returns the resident MB after it.
  double CheckOnce();
  int trims() const;

 private:
  void Loop();

  const MemoryTrimmerOptions options_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  double baseline_mb_ = -1;  // resident size after the last trim (or the lowest seen since)
  int trims_ = 0;
  std::thread thread_;
};

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_RUNTIME_MEMORY_TRIMMER_H_
