#include "client/load/server_usage.h"

#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>
#include <string>
#include <system_error>
#include <vector>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/str_split.h"
#include "absl/strings/strip.h"

namespace waymark::cli {
namespace {

constexpr char kListenState[] = "0A";  // TCP_LISTEN in /proc/net/tcp's "st" column

// Inodes of the sockets listening on `port` in one /proc/net/tcp-style table:
//   sl local_address rem_address st tx_queue:rx_queue tr:when retrnsmt uid timeout inode ...
// with local_address "HEXIP:HEXPORT".
void ListeningInodes(const std::string& table, int port, std::set<std::string>* inodes) {
  std::ifstream in(table);
  std::string line;
  std::getline(in, line);  // header
  while (std::getline(in, line)) {
    const std::vector<absl::string_view> fields = absl::StrSplit(line, ' ', absl::SkipWhitespace());
    if (fields.size() < 10 || fields[3] != kListenState) continue;
    const size_t colon = fields[1].rfind(':');
    int local_port = 0;
    if (colon == absl::string_view::npos ||
        !absl::SimpleHexAtoi(fields[1].substr(colon + 1), &local_port) || local_port != port) {
      continue;
    }
    inodes->insert(std::string(fields[9]));
  }
}

}  // namespace

absl::StatusOr<pid_t> FindListeningProcess(int port, const std::string& proc_root) {
  std::set<std::string> inodes;
  ListeningInodes(proc_root + "/net/tcp", port, &inodes);
  ListeningInodes(proc_root + "/net/tcp6", port, &inodes);
  inodes.erase("0");  // a socket whose owner is gone
  if (inodes.empty()) {
    return absl::NotFoundError(absl::StrCat("no socket listens on port ", port, " here"));
  }
  std::set<std::string> targets;
  for (const std::string& inode : inodes) targets.insert(absl::StrCat("socket:[", inode, "]"));

  namespace fs = std::filesystem;
  std::error_code error;
  for (const fs::directory_entry& process : fs::directory_iterator(proc_root, error)) {
    pid_t pid = 0;
    if (!absl::SimpleAtoi(process.path().filename().string(), &pid)) continue;
    std::error_code fd_error;  // other users' descriptors are unreadable: skip them
    for (const fs::directory_entry& fd : fs::directory_iterator(process.path() / "fd", fd_error)) {
      std::error_code link_error;
      const fs::path target = fs::read_symlink(fd.path(), link_error);
      if (!link_error && targets.count(target.string()) > 0) return pid;
    }
  }
  return absl::NotFoundError(absl::StrCat(
      "port ", port, " listens, but its process is not readable here (another user's?)"));
}

absl::StatusOr<ProcessMemory> ReadProcessMemory(pid_t pid, const std::string& proc_root) {
  const std::string path = absl::StrCat(proc_root, "/", pid, "/status");
  std::ifstream in(path);
  if (!in) return absl::NotFoundError(absl::StrCat("process ", pid, " is gone (", path, ")"));
  ProcessMemory memory;
  bool found = false;
  std::string line;
  while (std::getline(in, line)) {
    // "VmRSS:\t  123456 kB"
    absl::string_view rest = line;
    int64_t* field = nullptr;
    if (absl::ConsumePrefix(&rest, "VmRSS:")) field = &memory.rss_bytes;
    if (absl::ConsumePrefix(&rest, "VmHWM:")) field = &memory.peak_rss_bytes;
    if (field == nullptr) continue;
    rest = absl::StripAsciiWhitespace(rest);
    int64_t kib = 0;
    if (absl::ConsumeSuffix(&rest, "kB") &&
        absl::SimpleAtoi(absl::StripAsciiWhitespace(rest), &kib)) {
      *field = kib * 1024;
      found = true;
    }
  }
  if (!found) {
    return absl::NotFoundError(absl::StrCat("no VmRSS in ", path, " (a kernel thread?)"));
  }
  return memory;
}

absl::StatusOr<double> ReadProcessCpuSeconds(pid_t pid, const std::string& proc_root) {
  const std::string path = absl::StrCat(proc_root, "/", pid, "/stat");
  std::ifstream in(path);
  std::string line;
  if (!in || !std::getline(in, line)) {
    return absl::NotFoundError(absl::StrCat("process ", pid, " is gone (", path, ")"));
  }
  // "PID (COMM) STATE PPID ...": COMM may hold spaces and parentheses, so count the fields from
  // the last ')'. utime and stime are fields 14 and 15 of the line, 12 and 13 after COMM.
  const size_t comm_end = line.rfind(')');
  const std::vector<absl::string_view> fields = absl::StrSplit(
      absl::string_view(line).substr(comm_end == std::string::npos ? 0 : comm_end + 1), ' ',
      absl::SkipWhitespace());
  int64_t user_ticks = 0, system_ticks = 0;
  if (comm_end == std::string::npos || fields.size() < 13 ||
      !absl::SimpleAtoi(fields[11], &user_ticks) || !absl::SimpleAtoi(fields[12], &system_ticks)) {
    return absl::DataLossError(absl::StrCat("cannot read the CPU times in ", path));
  }
  return static_cast<double>(user_ticks + system_ticks) / sysconf(_SC_CLK_TCK);
}

}  // namespace waymark::cli
