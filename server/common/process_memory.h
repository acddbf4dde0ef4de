#ifndef WAYMARK_SERVER_COMMON_PROCESS_MEMORY_H_
#define WAYMARK_SERVER_COMMON_PROCESS_MEMORY_H_

// The resident set size of this process, for the server's memory trimmer and the benchmarks.

#include <unistd.h>

#include <fstream>

namespace waymark {

// Resident memory of this process now, in MB (/proc/self/statm); -1 when it cannot be read.
inline double ResidentMegabytes() {
  std::ifstream statm("/proc/self/statm");
  long pages_total = 0, pages_resident = 0;
  if (!(statm >> pages_total >> pages_resident)) return -1;
  return static_cast<double>(pages_resident) * static_cast<double>(sysconf(_SC_PAGESIZE)) /
         (1024.0 * 1024.0);
}

}  // namespace waymark

#endif  // WAYMARK_SERVER_COMMON_PROCESS_MEMORY_H_
