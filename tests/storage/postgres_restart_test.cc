// A PostgreSQL server that restarts under the stores (issue 19): while it is down every call is
// UNAVAILABLE (transient, nothing written, no crash); once it is back the stores reconnect by
// themselves, and everything committed before is there. The test restarts a cluster of its own
// (tests/support/postgres_server.sh in a private state directory), not the suite's shared one.

#include <cstdlib>
#include <memory>
#include <string>

#include "gtest/gtest.h"
#include "storage/crossing_store.h"
#include "storage/open_stores.h"
#include "storage/postgres/pg_admin.h"
#include "storage/slam_store.h"
#include "tests/storage/status_testing.h"
#include "tests/storage/temp_dir.h"

namespace waymark::storage {
namespace {

using ::waymark::storage::testing::TempDir;

class PrivateServer {
 public:
  PrivateServer() {
    ok_ = Run("start") && !Uri().empty();
  }
  ~PrivateServer() { Run("stop"); }
  bool ok() const { return ok_; }
  bool Run(const std::string& action) {
    const std::string command = std::string(WAYMARK_SOURCE_DIR) +
                                "/tests/support/postgres_server.sh " + action + " " +
                                state_.path().string() + " >/dev/null 2>&1";
    return std::system(command.c_str()) == 0;
  }
  std::string Uri() const {
    FILE* file = std::fopen(state_.File("uri").c_str(), "r");
    if (file == nullptr) return "";
    char line[512] = {};
    const bool read = std::fgets(line, sizeof(line), file) != nullptr;
    std::fclose(file);
    std::string uri = read ? line : "";
    while (!uri.empty() && (uri.back() == '\n' || uri.back() == ' ')) uri.pop_back();
    return uri;
  }

 private:
  TempDir state_;
  bool ok_ = false;
};

TEST(PostgresRestartTest, CallsAreUnavailableWhileItIsDownAndWorkAgainAfterwards) {
  PrivateServer server;
  if (!server.ok()) GTEST_SKIP() << "no PostgreSQL server binaries (postgresql-15) to start one";
  ASSERT_OK_AND_ASSIGN(std::string uri, pg::RecreateDatabase(server.Uri(), "restart_test"));
  ASSERT_OK_AND_ASSIGN(Stores stores, OpenStores(uri));
  ASSERT_OK_AND_ASSIGN(DatabaseRecord city, stores.crossing->CreateDatabase("city", "{}"));
  SlamSessionRecord session;
  session.id = "00000000000000000000000000000001";
  session.robot_id = "r1";
  session.config = "c";
  ASSERT_OK(stores.slam->CreateSession(session));

  ASSERT_TRUE(server.Run("pause"));
  // Down: a precise transient error, nothing else.
  EXPECT_EQ(stores.crossing->AddCrossing(city.id, "A", "").status().code(),
            absl::StatusCode::kUnavailable);
  EXPECT_EQ(stores.crossing->ListDatabases().status().code(), absl::StatusCode::kUnavailable);
  EXPECT_EQ(stores.slam->GetSession(session.id).status().code(), absl::StatusCode::kUnavailable);
  EXPECT_EQ(stores.token->ListTokens().status().code(), absl::StatusCode::kUnavailable);

  // Back (a new server process on the same data and port): the pool reconnects on next use.
  ASSERT_TRUE(server.Run("resume"));
  ASSERT_OK_AND_ASSIGN(std::vector<DatabaseRecord> databases, stores.crossing->ListDatabases());
  ASSERT_EQ(databases.size(), 1u);
  EXPECT_EQ(databases[0].name, "city");
  ASSERT_OK(stores.crossing->AddCrossing(city.id, "A", ""));
  ASSERT_OK_AND_ASSIGN(SlamSessionRecord stored, stores.slam->GetSession(session.id));
  EXPECT_EQ(stored.robot_id, "r1");
}

TEST(PostgresRestartTest, ARestartBetweenCallsIsNotSeenByTheNextOnes) {
  PrivateServer server;
  if (!server.ok()) GTEST_SKIP() << "no PostgreSQL server binaries (postgresql-15) to start one";
  ASSERT_OK_AND_ASSIGN(std::string uri, pg::RecreateDatabase(server.Uri(), "restart_test"));
  ASSERT_OK_AND_ASSIGN(std::unique_ptr<CrossingStore> store, OpenCrossingStore(uri));
  ASSERT_OK(store->CreateDatabase("city", "{}"));
  ASSERT_TRUE(server.Run("restart"));
  // The pooled connection died with the old server process. A call that finds it dead may be
  // answered UNAVAILABLE once; the pool resets it, and the next call works.
  absl::StatusOr<std::vector<DatabaseRecord>> listed = store->ListDatabases();
  if (!listed.ok()) {
    EXPECT_EQ(listed.status().code(), absl::StatusCode::kUnavailable) << listed.status();
    listed = store->ListDatabases();
  }
  ASSERT_OK(listed.status());
  EXPECT_EQ(listed->size(), 1u);
}

}  // namespace
}  // namespace waymark::storage
