#ifndef WAYMARK_SERVER_SERVICE_RUNTIME_THREAD_STACK_FLOOR_H_
#define WAYMARK_SERVER_SERVICE_RUNTIME_THREAD_STACK_FLOOR_H_

// A floor under the stack size that libraries ask for their threads (thread_stack_floor.cc says
// why). Calling it does nothing; it exists so that a binary that starts the metrics endpoint links
// the interposer.

#include <cstddef>

#include "server/service/runtime/folder.h"

namespace waymark::service {

inline constexpr std::size_t kThreadStackFloor = 1 << 20;  // 1 MiB

// The smallest stack a thread can now be given (kThreadStackFloor).
std::size_t ThreadStackFloor();

}  // namespace waymark::service

#endif  // WAYMARK_SERVER_SERVICE_RUNTIME_THREAD_STACK_FLOOR_H_
