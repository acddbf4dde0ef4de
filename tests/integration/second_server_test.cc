// A second waymark-server on a database file that one already serves is refused with a message
// naming the first one's pid, and exits before it listens; once the first one has stopped (even
// by SIGKILL), a new server starts on the file.

#include <gtest/gtest.h>
#include <signal.h>

#include <filesystem>
#include <string>

#include "absl/strings/str_cat.h"
#include "tests/support/server_process.h"

namespace waymark {
namespace {

using testing::ServerProcess;

TEST(SecondServerTest, RefusedWhileTheFirstServesAndAcceptedAfterItStops) {
  const std::string dir = testing::MakeTempDir("waymark-second");
  const std::string db = dir + "/waymark.db";
  auto first = ServerProcess::Start(testing::ServerBinary(), db);
  ASSERT_TRUE(first.ok()) << first.status();

  // Start() reports a server that exits before listening, with its log. One that listened
  // instead (a regression) comes back OK and is killed when `second` goes away, so a broken lock
  // fails the test rather than hanging it.
  auto second = ServerProcess::Start(testing::ServerBinary(), db);
  ASSERT_FALSE(second.ok()) << "a second server started serving " << db;
  const std::string log(second.status().message());
  EXPECT_NE(log.find("exited before listening"), std::string::npos) << log;
  EXPECT_NE(
      log.find(absl::StrCat("database ", db, " is already served by another waymark-server (pid ",
                            (*first)->pid(), ")")),
      std::string::npos)
      << log;
  EXPECT_TRUE((*first)->Running()) << "the refused server disturbed the first one";

  // SIGKILL: the kernel releases the lock with the process; nothing stale is left to clean up.
  (*first)->Stop(SIGKILL);
  auto next = ServerProcess::Start(testing::ServerBinary(), db);
  ASSERT_TRUE(next.ok()) << next.status();
  EXPECT_EQ((*next)->Stop(SIGTERM), 0);
  if (!HasFailure()) std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace waymark
