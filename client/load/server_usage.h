#ifndef WAYMARK_CLIENT_LOAD_SERVER_USAGE_H_
#define WAYMARK_CLIENT_LOAD_SERVER_USAGE_H_

// What a server process on this machine uses, for `waymark bench load`: which process listens on
// the server's port, its resident set size and its CPU time. Linux /proc only; `proc_root` is
// injectable so tests can use a fake tree.

#include <sys/types.h>

#include <cstdint>
#include <string>

#include "absl/status/statusor.h"

namespace waymark::cli {

// The process listening on TCP `port` (any local address, IPv4 or IPv6): the LISTEN socket's inode
// from /proc/net/tcp and tcp6, then the process holding a descriptor on that socket. Descriptors
// of other users' processes are unreadable unless root, so a server of another user (or in a
// container) is NOT_FOUND: pass its pid instead.
absl::StatusOr<pid_t> FindListeningProcess(int port, const std::string& proc_root = "/proc");

struct ProcessMemory {
  int64_t rss_bytes = 0;       // VmRSS: resident now
  int64_t peak_rss_bytes = 0;  // VmHWM: the most ever resident
};

// From /proc/PID/status. NOT_FOUND once the process is gone.
absl::StatusOr<ProcessMemory> ReadProcessMemory(pid_t pid, const std::string& proc_root = "/proc");

// CPU seconds the process has used so far, user + system, all threads (/proc/PID/stat).
// NOT_FOUND once the process is gone.
absl::StatusOr<double> ReadProcessCpuSeconds(pid_t pid, const std::string& proc_root = "/proc");

}  // namespace waymark::cli

#endif  // WAYMARK_CLIENT_LOAD_SERVER_USAGE_H_
