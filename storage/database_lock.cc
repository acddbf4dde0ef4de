#include "storage/database_lock.h"

#include <errno.h>
#include <fcntl.h>
#include <sys/file.h>
#include <unistd.h>

#include <cstring>
#include <string>
#include <utility>

#include "absl/strings/numbers.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/strip.h"
#include "storage/store_util.h"

namespace waymark::storage {
namespace {

// The pid the holder wrote, or "unknown" while it has not yet (it writes right after locking).
std::string HolderPid(int fd) {
  char buffer[32] = {};
  const ssize_t n = pread(fd, buffer, sizeof(buffer) - 1, 0);
  int64_t pid = 0;
  if (n <= 0 || !absl::SimpleAtoi(absl::StripAsciiWhitespace(buffer), &pid) || pid <= 0) {
    return "unknown";
  }
  return absl::StrCat(pid);
}

// Replaces the file's content with our pid (a previous holder's may still be there).
void WritePid(int fd) {
  const std::string text = absl::StrCat(getpid(), "\n");
  // Best effort: the pid only improves the message another server prints.
  if (ftruncate(fd, 0) == 0) {
    (void)!pwrite(fd, text.data(), text.size(), 0);
  }
}

}  // namespace

std::string DatabaseLock::LockPath(const std::string& db_path) { return db_path + ".lock"; }

absl::StatusOr<DatabaseLock> DatabaseLock::Acquire(const std::string& db_path) {
  if (db_path == ":memory:") return DatabaseLock(-1);
  if (absl::Status s = EnsureParentDirectory(db_path); !s.ok()) return s;
  const std::string path = LockPath(db_path);
  // O_CLOEXEC: a child the server might exec must not inherit (and so keep holding) the lock.
  const int fd = open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0644);
  if (fd < 0) {
    return absl::InternalError(
        absl::StrCat("cannot open lock file \"", path, "\": ", std::strerror(errno)));
  }
  int rc;
  do {
    rc = flock(fd, LOCK_EX | LOCK_NB);
  } while (rc != 0 && errno == EINTR);
  if (rc != 0) {
    const int error = errno;
    const std::string pid = error == EWOULDBLOCK ? HolderPid(fd) : "";
    close(fd);
    if (error == EWOULDBLOCK) {
      return absl::FailedPreconditionError(
          absl::StrCat("database ", db_path, " is already served by another waymark-server (pid ",
                       pid, "); stop it first, or give this server another --db"));
    }
    return absl::InternalError(absl::StrCat("cannot lock \"", path, "\": ", std::strerror(error)));
  }
  WritePid(fd);
  return DatabaseLock(fd);
}

DatabaseLock::DatabaseLock(DatabaseLock&& other) noexcept : fd_(std::exchange(other.fd_, -1)) {}

DatabaseLock& DatabaseLock::operator=(DatabaseLock&& other) noexcept {
  if (this != &other) {
    if (fd_ >= 0) close(fd_);
    fd_ = std::exchange(other.fd_, -1);
  }
  return *this;
}

DatabaseLock::~DatabaseLock() {
  if (fd_ >= 0) close(fd_);
}

}  // namespace waymark::storage
