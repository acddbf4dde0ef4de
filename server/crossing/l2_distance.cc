#include "server/crossing/l2_distance.h"

#include <cstdlib>

namespace waymark::crossing {

// One binary runs on any x86-64; the loader picks the AVX2 clone where the CPU supports it
// (the build machine is not necessarily the machine that runs the server, e.g. Docker images).
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__)
__attribute__((target_clones("avx2", "default")))
#endif
int32_t SquaredL2(const uint8_t* a, const uint8_t* b) {
  int32_t sum = 0;
  for (int i = 0; i < 128; ++i) {
    const int32_t d = static_cast<int32_t>(a[i]) - static_cast<int32_t>(b[i]);
    sum += d * d;
  }
  return sum;
}

}  // namespace waymark::crossing
