// Why: the metrics endpoint is prometheus-cpp's, served by civetweb, whose Debian build gives its
// worker threads 100 KiB of stack (USE_STACK_SIZE, with no run-time option). Ceres (the laser
// pose graph) links SuiteSparse and LAPACK, which bring libgfortran and with it libquadmath, whose
// constructor registers printf handlers for __float128. From then on glibc formats every printf
// on its slower "positional" path, which needs more stack: civetweb's 100 KiB overflowed on the
// first scrape (a segfault in mg_printf). Interposing pthread_attr_setstacksize in the executable
// raises every requested stack to at least 1 MiB; larger requests are left as they are.

#include "server/service/runtime/thread_stack_floor.h"

#include <dlfcn.h>
#include <pthread.h>

#include <algorithm>

extern "C" int pthread_attr_setstacksize(pthread_attr_t* attr, size_t size) {
  using Real = int (*)(pthread_attr_t*, size_t);
  static const Real real = reinterpret_cast<Real>(dlsym(RTLD_NEXT, "pthread_attr_setstacksize"));
  if (real == nullptr) return 0;  // cannot happen with glibc; keep the default stack then
  return real(attr, std::max(size, waymark::service::kThreadStackFloor));
}

namespace waymark::service {

std::size_t ThreadStackFloor() { return kThreadStackFloor; }

}  // namespace waymark::service
