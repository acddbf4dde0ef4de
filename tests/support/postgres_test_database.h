#ifndef WAYMARK_TESTS_SUPPORT_POSTGRES_TEST_DATABASE_H_
#define WAYMARK_TESTS_SUPPORT_POSTGRES_TEST_DATABASE_H_

// A fresh PostgreSQL database for one test (issue 19), on the server that ctest starts before the
// tests that need it (tests/support/postgres_server.sh, the `postgres` fixture in
// tests/CMakeLists.txt). Each test gets its own database, dropped afterwards, so tests that ctest
// runs in parallel never see each other's rows. Without a server, available() is false and
// skip_reason() says why and how to get one: the test skips. A server that is there but cannot
// create a database fails the test.

#include <string>

namespace waymark::testing {

class PostgresTestDatabase {
 public:
  PostgresTestDatabase();
  ~PostgresTestDatabase();
  PostgresTestDatabase(const PostgresTestDatabase&) = delete;
  PostgresTestDatabase& operator=(const PostgresTestDatabase&) = delete;

  bool available() const { return !uri_.empty(); }
  const std::string& skip_reason() const { return skip_reason_; }
  // The libpq URI of this test's database.
  const std::string& uri() const { return uri_; }
  // The server's maintenance database, e.g. to run commands beside the stores.
  const std::string& server_uri() const { return server_uri_; }

 private:
  std::string server_uri_;
  std::string name_;
  std::string uri_;
  std::string skip_reason_;
};

// The test server's URI (WAYMARK_TEST_POSTGRES_URI, or the one postgres_server.sh wrote into the
// build directory); empty when neither is there.
std::string PostgresTestServerUri();

}  // namespace waymark::testing

#endif  // WAYMARK_TESTS_SUPPORT_POSTGRES_TEST_DATABASE_H_
