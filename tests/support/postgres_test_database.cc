#include "tests/support/postgres_test_database.h"

#include <unistd.h>

#include <atomic>
#include <cstdlib>
#include <fstream>
#include <memory>
#include <random>

#include "absl/strings/str_cat.h"
#include "gtest/gtest.h"
#include "absl/strings/strip.h"
#include "storage/postgres/pg_admin.h"

namespace waymark::testing {

std::string PostgresTestServerUri() {
  if (const char* env = std::getenv("WAYMARK_TEST_POSTGRES_URI"); env != nullptr && *env != '\0') {
    return env;
  }
  std::ifstream file(WAYMARK_BINARY_DIR "/pgtest/uri");
  std::string uri;
  std::getline(file, uri);
  return std::string(absl::StripAsciiWhitespace(uri));
}

PostgresTestDatabase::PostgresTestDatabase() {
  server_uri_ = PostgresTestServerUri();
  if (server_uri_.empty()) {
    skip_reason_ =
        "no PostgreSQL test server: run the tests through ctest (`make test`), which starts one "
        "with tests/support/postgres_server.sh, or set WAYMARK_TEST_POSTGRES_URI";
    return;
  }
  static std::atomic<int> counter{0};
  std::random_device random;
  name_ = absl::StrCat("waymark_test_", getpid(), "_", counter++, "_", random() % 100000);
  absl::StatusOr<std::string> uri = storage::pg::RecreateDatabase(server_uri_, name_);
  if (!uri.ok()) {
    // The server is there but does not work: that is a failure, not a reason to skip.
    skip_reason_ = absl::StrCat("cannot create a test database on the PostgreSQL test server: ",
                                uri.status().message());
    ADD_FAILURE() << skip_reason_;
    name_.clear();
    return;
  }
  uri_ = *uri;
}

PostgresTestDatabase::~PostgresTestDatabase() {
  if (!name_.empty()) storage::pg::DropDatabase(server_uri_, name_).IgnoreError();
}

}  // namespace waymark::testing
