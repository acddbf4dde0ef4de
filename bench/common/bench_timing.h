#ifndef WAYMARK_BENCH_COMMON_BENCH_TIMING_H_
#define WAYMARK_BENCH_COMMON_BENCH_TIMING_H_

// Small helpers the engine benchmarks share: reading a model file, process CPU time (every
// worker thread included), percentiles of timings and the load average that says how much to
// trust wall times on a shared machine.

#include <stdlib.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "server/common/process_memory.h"

namespace waymark::bench {

inline std::string ReadFileBytes(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// CPU milliseconds of the whole process so far.
inline double ProcessCpuMs() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return t.tv_sec * 1e3 + t.tv_nsec / 1e6;
}

// Resident memory of the process now, in MB (0 when /proc is not there).
inline double ResidentMb() { return std::max(0.0, waymark::ResidentMegabytes()); }

// The q-quantile (0..1, nearest rank) of `values`; 0 for none.
inline double Percentile(std::vector<double> values, double q) {
  if (values.empty()) return 0;
  std::sort(values.begin(), values.end());
  const size_t i = static_cast<size_t>(q * (values.size() - 1) + 0.5);
  return values[std::min(i, values.size() - 1)];
}

// "1.23 0.98 0.75" (1, 5 and 15 minutes), or "unknown".
inline std::string LoadAverageText() {
  double load[3] = {0, 0, 0};
  if (getloadavg(load, 3) != 3) return "unknown";
  char text[64];
  std::snprintf(text, sizeof text, "%.2f %.2f %.2f", load[0], load[1], load[2]);
  return text;
}

}  // namespace waymark::bench

#endif  // WAYMARK_BENCH_COMMON_BENCH_TIMING_H_
