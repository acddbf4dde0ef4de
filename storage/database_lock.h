#ifndef WAYMARK_STORAGE_DATABASE_LOCK_H_
#define WAYMARK_STORAGE_DATABASE_LOCK_H_

// One serving process per database file. A waymark-server keeps every crossing database in memory
// and writes through to the file, so a second server on the same file would answer from a memory
// that the first one's enrollments never reach (and vice versa): SQLite would keep the file
// intact, but the two processes would disagree about what it holds. The second one is refused
// instead, with a message that names the process that serves the file.
//
// How: an exclusive flock() on "<db>.lock" beside the database, held while the server runs; the
// holder's pid is written into it for the message. The kernel drops the lock when the process
// dies in any way (kill -9 included), so there is never a stale lock to clean up by hand.
//
// Why a separate file and not flock() on the database itself: SQLite locks the database with
// POSIX fcntl() locks, which belong to the process and are all released when the process closes
// *any* descriptor of that file. Opening the database file a second time just to lock it would
// therefore put SQLite's own locking at the mercy of our close(). flock() locks are independent of
// fcntl() locks on Linux, but on NFS the kernel emulates flock() with fcntl() and the two would
// collide on the database file; on a file of its own they cannot.
//
// The lock file is never deleted: unlinking it while another process waits on the old inode would
// let a third process lock a new inode, and two servers would each hold "the" lock.
//
// Only the serving path takes the lock. Administrative commands (e.g. token management) open the
// database next to a running server on purpose; SQLite (WAL, busy timeout) makes that safe.

#include <string>

#include "absl/status/statusor.h"

namespace waymark::storage {

class DatabaseLock {
 public:
  // Takes the lock for serving `db_path`, creating the lock file (and its directory) if needed.
  // FAILED_PRECONDITION "database FILE is already served by another waymark-server (pid N)" when
  // another process (or another DatabaseLock in this one) holds it; INTERNAL when the lock file
  // cannot be created. ":memory:" needs no lock (no other process can open it).
  static absl::StatusOr<DatabaseLock> Acquire(const std::string& db_path);

  // The lock file for a database file: "<db_path>.lock".
  static std::string LockPath(const std::string& db_path);

  DatabaseLock(DatabaseLock&& other) noexcept;
  DatabaseLock& operator=(DatabaseLock&& other) noexcept;
  DatabaseLock(const DatabaseLock&) = delete;
  DatabaseLock& operator=(const DatabaseLock&) = delete;
  // Releases the lock (closing the descriptor is enough; the file stays).
  ~DatabaseLock();

 private:
  explicit DatabaseLock(int fd) : fd_(fd) {}

  int fd_ = -1;  // -1 for ":memory:" or once moved from
};

}  // namespace waymark::storage

#endif  // WAYMARK_STORAGE_DATABASE_LOCK_H_
