// DatabaseLock: one serving process per database file, a precise refusal for the second one, and
// no stale lock after the holder dies (kill -9 included).

#include "storage/database_lock.h"

#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <utility>

#include "absl/strings/str_cat.h"
#include "gtest/gtest.h"
#include "storage/sqlite.h"
#include "tests/storage/status_testing.h"
#include "tests/storage/temp_dir.h"

namespace waymark::storage {
namespace {

using testing::TempDir;

std::string ReadText(const std::string& path) {
  std::ifstream in(path);
  std::stringstream text;
  text << in.rdbuf();
  return text.str();
}

TEST(DatabaseLockTest, SecondHolderIsRefusedWithTheFirstOnesPid) {
  TempDir dir;
  const std::string db = dir.File("waymark.db");
  absl::StatusOr<DatabaseLock> first = DatabaseLock::Acquire(db);
  ASSERT_OK(first.status());
  EXPECT_EQ(DatabaseLock::LockPath(db), db + ".lock");
  EXPECT_EQ(ReadText(db + ".lock"), absl::StrCat(getpid(), "\n"));

  // flock() locks belong to the open file, so a second open in the same process conflicts too.
  absl::StatusOr<DatabaseLock> second = DatabaseLock::Acquire(db);
  ASSERT_FALSE(second.ok());
  EXPECT_EQ(second.status().code(), absl::StatusCode::kFailedPrecondition);
  EXPECT_NE(
      second.status().message().find(absl::StrCat(
          "database ", db, " is already served by another waymark-server (pid ", getpid(), ")")),
      std::string::npos)
      << second.status();
}

TEST(DatabaseLockTest, ReleasedOnDestructionAndKeptAcrossMoves) {
  TempDir dir;
  const std::string db = dir.File("waymark.db");
  {
    absl::StatusOr<DatabaseLock> lock = DatabaseLock::Acquire(db);
    ASSERT_OK(lock.status());
    DatabaseLock moved = std::move(*lock);
    EXPECT_FALSE(DatabaseLock::Acquire(db).ok()) << "the moved-to lock must still hold";
  }
  EXPECT_OK(DatabaseLock::Acquire(db).status());
  // The file stays (deleting it could hand two processes two different inodes to lock).
  EXPECT_TRUE(std::filesystem::exists(db + ".lock"));
}

TEST(DatabaseLockTest, OtherDatabasesAndMemoryAreIndependent) {
  TempDir dir;
  absl::StatusOr<DatabaseLock> a = DatabaseLock::Acquire(dir.File("a.db"));
  ASSERT_OK(a.status());
  EXPECT_OK(DatabaseLock::Acquire(dir.File("b.db")).status());
  absl::StatusOr<DatabaseLock> memory = DatabaseLock::Acquire(":memory:");
  ASSERT_OK(memory.status());
  EXPECT_OK(DatabaseLock::Acquire(":memory:").status());
}

TEST(DatabaseLockTest, CreatesTheDirectoryAndReportsAnUnusablePath) {
  TempDir dir;
  const std::string db = (dir.path() / "var" / "nested" / "waymark.db").string();
  EXPECT_OK(DatabaseLock::Acquire(db).status());
  EXPECT_TRUE(std::filesystem::exists(db + ".lock"));

  // A regular file where the directory should be.
  std::ofstream(dir.File("file")) << "x";
  absl::StatusOr<DatabaseLock> bad = DatabaseLock::Acquire(dir.File("file") + "/waymark.db");
  ASSERT_FALSE(bad.ok());
  EXPECT_EQ(bad.status().code(), absl::StatusCode::kInternal);
  EXPECT_NE(bad.status().message().find(dir.File("file")), std::string::npos) << bad.status();
}

// SQLite's own locking is untouched: a connection on the database works while the lock is held,
// and opening and closing connections does not release the lock (it is not an fcntl() lock).
TEST(DatabaseLockTest, IndependentOfSqliteLocks) {
  TempDir dir;
  const std::string db = dir.File("waymark.db");
  absl::StatusOr<DatabaseLock> lock = DatabaseLock::Acquire(db);
  ASSERT_OK(lock.status());
  for (int i = 0; i < 2; ++i) {
    absl::StatusOr<sqlite::Connection> connection = sqlite::Connection::Open(db);
    ASSERT_OK(connection.status());
    ASSERT_OK(
        connection->Exec("CREATE TABLE IF NOT EXISTS t (x INTEGER); INSERT INTO t VALUES (1)"));
  }
  EXPECT_FALSE(DatabaseLock::Acquire(db).ok());
}

// Another process holds the lock, then dies by SIGKILL: the kernel releases it, no cleanup needed.
TEST(DatabaseLockTest, HolderKilledWithSigkillLeavesNoStaleLock) {
  TempDir dir;
  const std::string db = dir.File("waymark.db");
  int ready[2];
  ASSERT_EQ(pipe(ready), 0);
  const pid_t child = fork();
  ASSERT_GE(child, 0);
  if (child == 0) {
    close(ready[0]);
    absl::StatusOr<DatabaseLock> lock = DatabaseLock::Acquire(db);
    const char byte = lock.ok() ? '1' : '0';
    (void)!write(ready[1], &byte, 1);
    while (true) pause();
  }
  close(ready[1]);
  // Never leave the child behind, whatever fails below.
  struct Reaper {
    pid_t pid;
    ~Reaper() {
      if (pid > 0) {
        kill(pid, SIGKILL);
        waitpid(pid, nullptr, 0);
      }
    }
  } reaper{child};
  char byte = 0;
  ASSERT_EQ(read(ready[0], &byte, 1), 1);
  close(ready[0]);
  ASSERT_EQ(byte, '1') << "the child could not take the lock";

  absl::StatusOr<DatabaseLock> refused = DatabaseLock::Acquire(db);
  ASSERT_FALSE(refused.ok());
  EXPECT_NE(refused.status().message().find(absl::StrCat("(pid ", child, ")")), std::string::npos)
      << refused.status();

  kill(child, SIGKILL);
  ASSERT_EQ(waitpid(child, nullptr, 0), child);
  reaper.pid = -1;
  EXPECT_OK(DatabaseLock::Acquire(db).status());
}

}  // namespace
}  // namespace waymark::storage
