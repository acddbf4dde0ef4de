#ifndef WAYMARK_SERVER_SERVICE_RUNTIME_MEMORY_TRIMMER_H_
#define WAYMARK_SERVER_SERVICE_RUNTIME_MEMORY_TRIMMER_H_

// Gives freed heap back to the system. glibc keeps what the request threads free in their
// arenas: after a burst of large concurrent inputs (enrollments, big scans) the server's resident
// memory stayed at the burst's peak for good, although nothing held it (issue 21: 64 MB at
// start, 929 MB at the end of a campaign with no leak found). Every `period` this checks the
// resident size and, when it grew by more than `growth_mb` since the last trim, calls
// malloc_trim, which returns the arenas' free pages.
//
// Growth alone misses the moment most memory is freed: when sessions close (issue 38: 20 robots
// took the server from 66 to 262 MB; closing all their sessions gave back only 23 MB, since
// nothing grew after the close, so nothing trimmed). Whoever frees a large structure calls
// TrimSoon: the thread trims once within `settle_seconds`, however many asked meanwhile.

#include <condition_variable>
#include <mutex>
#include <thread>

#include "server/service/runtime/folder.h"

namespace waymark::service {

struct MemoryTrimmerOptions {
  double period_seconds = 10;
  double growth_mb = 32;
  // How long TrimSoon waits before trimming, so that a burst of frees (every session of a fleet
  // closing at once) costs one trim.
  double settle_seconds = 0.5;
};

class MemoryTrimmer {
 public:
  explicit MemoryTrimmer(MemoryTrimmerOptions options = {});
  ~MemoryTrimmer();
  MemoryTrimmer(const MemoryTrimmer&) = delete;
  MemoryTrimmer& operator=(const MemoryTrimmer&) = delete;

  // One check now (what the thread does every period); returns the resident MB after it.
  double CheckOnce();
  // Asks for one trim within settle_seconds whatever the growth (large structures were just
  // freed); requests made before it runs are served by that one trim. Returns at once; without
  // the thread (period_seconds = 0) it trims now. Any thread; never blocks on the trim itself.
  void TrimSoon();
  int trims() const;

 private:
  void Loop();
  // malloc_trim, then the new baseline; mutex_ not held.
  double Trim(double resident_before);

  const MemoryTrimmerOptions options_;
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  bool stopping_ = false;
  bool trim_requested_ = false;  // TrimSoon called since the last trim
  double baseline_mb_ = -1;  // resident size after the last trim (or the lowest seen since)
  int trims_ = 0;
  std::thread thread_;
};

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_RUNTIME_MEMORY_TRIMMER_H_
