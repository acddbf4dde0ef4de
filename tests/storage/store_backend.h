#ifndef WAYMARK_TESTS_STORAGE_STORE_BACKEND_H_
#define WAYMARK_TESTS_STORAGE_STORE_BACKEND_H_

// One store suite, run against both backends (issue 19): a test is parameterised by Backend and
// opens its stores on a TestDatabase, a SQLite file in a fresh directory or a fresh PostgreSQL
// database on the test server. Without a PostgreSQL server the PostgreSQL half skips, saying why.

#include <cstdint>
#include <memory>
#include <string>

#include "absl/status/statusor.h"
#include "absl/strings/str_cat.h"
#include "gtest/gtest.h"
#include "storage/open_stores.h"
#include "storage/postgres/pg.h"
#include "storage/sqlite.h"
#include "tests/storage/temp_dir.h"
#include "tests/support/postgres_test_database.h"

namespace waymark::storage::testing {

enum class Backend { kSqlite, kPostgres };

inline const auto kBothBackends = ::testing::Values(Backend::kSqlite, Backend::kPostgres);

// "Sqlite" / "Postgres", as the instantiated tests' name suffix.
inline std::string BackendName(const ::testing::TestParamInfo<Backend>& info) {
  return info.param == Backend::kSqlite ? "Sqlite" : "Postgres";
}

// The database one test runs against; every Open*Store(db()) of the test sees the same data.
class TestDatabase {
 public:
  explicit TestDatabase(Backend backend, const std::string& file_name = "waymark.db")
      : backend_(backend) {
    if (backend == Backend::kSqlite) {
      db_ = dir_.File(file_name);
    } else {
      postgres_ = std::make_unique<waymark::testing::PostgresTestDatabase>();
      db_ = postgres_->uri();
    }
  }

  Backend backend() const { return backend_; }
  bool available() const { return !db_.empty(); }
  std::string skip_reason() const { return postgres_ ? postgres_->skip_reason() : ""; }
  // The --db value: a file path or a libpq URI.
  const std::string& db() const { return db_; }

  // Rows in `table` (ours, never a client's), optionally filtered by a WHERE clause, read beside
  // the stores through a raw connection, so that a test sees what is really stored.
  absl::StatusOr<int64_t> CountRows(const std::string& table, const std::string& where = "") const {
    return QueryInt(absl::StrCat("SELECT COUNT(*) FROM ", table,
                                 where.empty() ? "" : absl::StrCat(" WHERE ", where)));
  }

  // The first column of the first row of `sql`, an integer.
  absl::StatusOr<int64_t> QueryInt(const std::string& sql) const {
    if (backend_ == Backend::kPostgres) {
      auto connection = pg::Connection::Open(db_);
      if (!connection.ok()) return connection.status();
      auto result = (*connection)->Execute(sql);
      if (!result.ok()) return result.status();
      if (result->rows() == 0) return absl::NotFoundError(absl::StrCat("no row: ", sql));
      return result->Int64(0, 0);
    }
    auto connection = sqlite::Connection::Open(db_);
    if (!connection.ok()) return connection.status();
    auto select = connection->Prepare(sql);
    if (!select.ok()) return select.status();
    auto step = select->Step();
    if (!step.ok()) return step.status();
    if (*step != sqlite::StepResult::kRow) return absl::NotFoundError(absl::StrCat("no row: ", sql));
    return select->ColumnInt64(0);
  }

  // Runs SQL beside the stores (e.g. to corrupt a row on purpose).
  absl::Status Exec(const std::string& sql) const {
    if (backend_ == Backend::kPostgres) {
      auto connection = pg::Connection::Open(db_);
      if (!connection.ok()) return connection.status();
      return (*connection)->Script(sql);
    }
    auto connection = sqlite::Connection::Open(db_);
    if (!connection.ok()) return connection.status();
    return connection->Exec(sql);
  }

 private:
  Backend backend_;
  TempDir dir_;
  std::unique_ptr<waymark::testing::PostgresTestDatabase> postgres_;
  std::string db_;
};

}  // namespace waymark::storage::testing

// Skips the test (with the reason) when its backend has no server to run against.
#define WAYMARK_SKIP_WITHOUT(database)                                \
  do {                                                                \
    if (!(database).available()) GTEST_SKIP() << (database).skip_reason(); \
  } while (false)

#endif  // WAYMARK_TESTS_STORAGE_STORE_BACKEND_H_
