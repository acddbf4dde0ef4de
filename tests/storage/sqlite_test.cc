// The RAII wrapper against a real SQLite: pragmas, binding and reading every type, error mapping,
// transactions and two connections on one WAL file.

#include "storage/sqlite.h"

#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstring>
#include <limits>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "gtest/gtest.h"
#include "tests/storage/status_testing.h"
#include "tests/storage/temp_dir.h"

namespace waymark::storage::sqlite {
namespace {

using ::waymark::storage::testing::CodeOf;
using ::waymark::storage::testing::TempDir;

// The single value a one-row, one-column query returns, as text.
std::string QueryText(Connection& connection, const std::string& sql) {
  absl::StatusOr<Statement> stmt = connection.Prepare(sql);
  if (!stmt.ok()) return "error: " + stmt.status().ToString();
  absl::StatusOr<StepResult> step = stmt->Step();
  if (!step.ok() || *step != StepResult::kRow) return "no row";
  return stmt->ColumnText(0);
}

int64_t CountRows(Connection& connection, const std::string& table) {
  return std::stoll(QueryText(connection, "SELECT COUNT(*) FROM " + table));
}

TEST(ConnectionTest, FileConnectionUsesWalForeignKeysAndNormalSync) {
  TempDir dir;
  ASSERT_OK_AND_ASSIGN(Connection connection, Connection::Open(dir.File("a.db")));
  EXPECT_EQ(QueryText(connection, "PRAGMA journal_mode"), "wal");
  EXPECT_EQ(QueryText(connection, "PRAGMA foreign_keys"), "1");
  EXPECT_EQ(QueryText(connection, "PRAGMA synchronous"), "1");  // NORMAL
  EXPECT_EQ(connection.path(), dir.File("a.db"));
}

// A writer behind another connection's open write transaction waits for it (the busy handler)
// instead of failing with "database is locked".
TEST(ConnectionTest, AWriterWaitsForAnotherWritersTransaction) {
  TempDir dir;
  ASSERT_OK_AND_ASSIGN(Connection first, Connection::Open(dir.File("a.db")));
  ASSERT_OK(first.Exec("CREATE TABLE t (x INTEGER)"));
  ASSERT_OK_AND_ASSIGN(Connection second, Connection::Open(dir.File("a.db")));
  ASSERT_OK(first.Exec("BEGIN IMMEDIATE"));
  ASSERT_OK(first.Exec("INSERT INTO t VALUES (1)"));
  std::thread commit_later([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
    EXPECT_OK(first.Exec("COMMIT"));
  });
  EXPECT_OK(second.Exec("INSERT INTO t VALUES (2)"));  // waits for the commit above
  commit_later.join();
  EXPECT_EQ(CountRows(second, "t"), 2);
}

TEST(ConnectionTest, InMemoryDatabaseOpens) {
  ASSERT_OK_AND_ASSIGN(Connection connection, Connection::Open(":memory:"));
  ASSERT_OK(connection.Exec("CREATE TABLE t (x INTEGER)"));
  EXPECT_EQ(QueryText(connection, "PRAGMA foreign_keys"), "1");
}

TEST(ConnectionTest, OpenFailureCarriesSqliteMessage) {
  TempDir dir;
  absl::StatusOr<Connection> missing_dir = Connection::Open(dir.File("no/such/dir/a.db"));
  ASSERT_FALSE(missing_dir.ok());
  EXPECT_EQ(missing_dir.status().code(), absl::StatusCode::kInternal);
  EXPECT_NE(missing_dir.status().message().find("unable to open"), absl::string_view::npos)
      << missing_dir.status();

  // Without SQLITE_OPEN_CREATE a missing file is an error, not a new database.
  EXPECT_FALSE(Connection::Open(dir.File("absent.db"), SQLITE_OPEN_READWRITE).ok());
}

TEST(ConnectionTest, MoveTransfersTheHandle) {
  ASSERT_OK_AND_ASSIGN(Connection a, Connection::Open(":memory:"));
  ASSERT_OK(a.Exec("CREATE TABLE t (x INTEGER)"));
  Connection b = std::move(a);
  EXPECT_EQ(a.raw(), nullptr);  // NOLINT(bugprone-use-after-move): checking the moved-from state
  ASSERT_OK(b.Exec("INSERT INTO t VALUES (1)"));
  EXPECT_EQ(CountRows(b, "t"), 1);
}

TEST(StatementTest, BindsAndReadsBackEveryTypeBitExact) {
  ASSERT_OK_AND_ASSIGN(Connection connection, Connection::Open(":memory:"));
  ASSERT_OK(connection.Exec("CREATE TABLE t (i INTEGER, d REAL, s TEXT, b BLOB, f BLOB, n BLOB)"));

  const int64_t big = std::numeric_limits<int64_t>::min();
  const double pi = 3.141592653589793;
  const std::string text("naïve\0text", 11);  // UTF-8 and an embedded NUL
  std::vector<uint8_t> bytes(256);
  for (int i = 0; i < 256; ++i) bytes[i] = static_cast<uint8_t>(i);
  // Values a lossy encoding would alter: signed zero, denormal, infinities, a NaN payload.
  uint32_t nan_bits = 0x7fc01234;
  float payload_nan;
  std::memcpy(&payload_nan, &nan_bits, sizeof(float));
  const std::vector<float> floats = {0.0f,
                                     -0.0f,
                                     1.0f / 3.0f,
                                     std::numeric_limits<float>::denorm_min(),
                                     std::numeric_limits<float>::max(),
                                     std::numeric_limits<float>::infinity(),
                                     -std::numeric_limits<float>::infinity(),
                                     payload_nan};

  ASSERT_OK_AND_ASSIGN(Statement insert,
                       connection.Prepare("INSERT INTO t VALUES (?, ?, ?, ?, ?, ?)"));
  ASSERT_OK(insert.BindInt64(1, big));
  ASSERT_OK(insert.BindDouble(2, pi));
  ASSERT_OK(insert.BindText(3, text));
  ASSERT_OK(insert.BindBlob(4, bytes));
  ASSERT_OK(insert.BindBlob(5, floats));
  ASSERT_OK(insert.BindNull(6));
  ASSERT_OK(insert.Run());
  EXPECT_EQ(connection.LastInsertRowId(), 1);
  EXPECT_EQ(connection.Changes(), 1);

  ASSERT_OK_AND_ASSIGN(Statement select, connection.Prepare("SELECT i, d, s, b, f, n FROM t"));
  ASSERT_OK_AND_ASSIGN(StepResult step, select.Step());
  ASSERT_EQ(step, StepResult::kRow);
  EXPECT_EQ(select.ColumnCount(), 6);
  EXPECT_EQ(select.ColumnInt64(0), big);
  EXPECT_EQ(select.ColumnDouble(1), pi);
  EXPECT_EQ(select.ColumnText(2), text);
  EXPECT_EQ(select.ColumnBlob(3), bytes);
  ASSERT_OK_AND_ASSIGN(std::vector<float> read_floats, select.ColumnFloatBlob(4));
  ASSERT_EQ(read_floats.size(), floats.size());
  EXPECT_EQ(std::memcmp(read_floats.data(), floats.data(), floats.size() * sizeof(float)), 0);
  EXPECT_TRUE(select.ColumnIsNull(5));
  EXPECT_FALSE(select.ColumnIsNull(3));
  ASSERT_OK_AND_ASSIGN(step, select.Step());
  EXPECT_EQ(step, StepResult::kDone);
}

TEST(StatementTest, EmptyBlobIsStoredAsEmptyNotNull) {
  ASSERT_OK_AND_ASSIGN(Connection connection, Connection::Open(":memory:"));
  ASSERT_OK(connection.Exec("CREATE TABLE t (b BLOB NOT NULL, f BLOB NOT NULL)"));
  ASSERT_OK_AND_ASSIGN(Statement insert, connection.Prepare("INSERT INTO t VALUES (?, ?)"));
  ASSERT_OK(insert.BindBlob(1, std::vector<uint8_t>()));
  ASSERT_OK(insert.BindBlob(2, std::vector<float>()));
  ASSERT_OK(insert.Run());  // NOT NULL would reject a NULL
  EXPECT_EQ(QueryText(connection, "SELECT typeof(b) || ',' || length(b) FROM t"), "blob,0");

  ASSERT_OK_AND_ASSIGN(Statement select, connection.Prepare("SELECT b, f FROM t"));
  ASSERT_OK(select.Step());
  EXPECT_TRUE(select.ColumnBlob(0).empty());
  ASSERT_OK_AND_ASSIGN(std::vector<float> floats, select.ColumnFloatBlob(1));
  EXPECT_TRUE(floats.empty());
}

TEST(StatementTest, FloatBlobWithPartialFloatIsDataLoss) {
  ASSERT_OK_AND_ASSIGN(Connection connection, Connection::Open(":memory:"));
  ASSERT_OK_AND_ASSIGN(Statement select, connection.Prepare("SELECT x'0102030405' AS f"));
  ASSERT_OK(select.Step());
  absl::StatusOr<std::vector<float>> floats = select.ColumnFloatBlob(0);
  EXPECT_EQ(floats.status().code(), absl::StatusCode::kDataLoss);
  EXPECT_NE(floats.status().message().find("5 bytes"), absl::string_view::npos) << floats.status();
}

TEST(StatementTest, PrepareErrorCarriesSqliteMessage) {
  ASSERT_OK_AND_ASSIGN(Connection connection, Connection::Open(":memory:"));
  absl::StatusOr<Statement> stmt = connection.Prepare("SELECT * FROM missing");
  EXPECT_EQ(stmt.status().code(), absl::StatusCode::kInternal);
  EXPECT_NE(stmt.status().message().find("no such table: missing"), absl::string_view::npos)
      << stmt.status();
}

TEST(StatementTest, PrepareRefusesSeveralStatements) {
  ASSERT_OK_AND_ASSIGN(Connection connection, Connection::Open(":memory:"));
  ASSERT_OK(connection.Exec("CREATE TABLE t (x INTEGER)"));
  EXPECT_FALSE(connection.Prepare("DELETE FROM t; DROP TABLE t").ok());
  EXPECT_OK(connection.Prepare("DELETE FROM t; ").status());  // trailing separators are fine
  EXPECT_FALSE(connection.Prepare("   ").ok());
}

TEST(StatementTest, UniqueViolationIsAlreadyExistsOnlyWhenAsked) {
  ASSERT_OK_AND_ASSIGN(Connection connection, Connection::Open(":memory:"));
  ASSERT_OK(connection.Exec("CREATE TABLE t (name TEXT UNIQUE)"));
  ASSERT_OK(connection.Exec("INSERT INTO t VALUES ('a')"));
  ASSERT_OK_AND_ASSIGN(Statement insert, connection.Prepare("INSERT INTO t VALUES (?)"));
  ASSERT_OK(insert.BindText(1, "a"));

  absl::Status as_internal = insert.Run();
  EXPECT_EQ(as_internal.code(), absl::StatusCode::kInternal);
  EXPECT_NE(as_internal.message().find("UNIQUE constraint failed: t.name"), absl::string_view::npos)
      << as_internal;

  insert.Reset();
  absl::Status as_exists = insert.Run(UniqueViolation::kAlreadyExists);
  EXPECT_EQ(as_exists.code(), absl::StatusCode::kAlreadyExists) << as_exists;
}

TEST(StatementTest, OtherConstraintsStayInternalEvenWhenAskingForAlreadyExists) {
  ASSERT_OK_AND_ASSIGN(Connection connection, Connection::Open(":memory:"));
  ASSERT_OK(
      connection.Exec("CREATE TABLE parent (id INTEGER PRIMARY KEY);"
                      "CREATE TABLE child (p INTEGER REFERENCES parent(id))"));
  ASSERT_OK_AND_ASSIGN(Statement insert, connection.Prepare("INSERT INTO child VALUES (42)"));
  absl::Status status = insert.Run(UniqueViolation::kAlreadyExists);
  EXPECT_EQ(status.code(), absl::StatusCode::kInternal);  // foreign keys are enforced
  EXPECT_NE(status.message().find("FOREIGN KEY constraint failed"), absl::string_view::npos)
      << status;
}

TEST(StatementTest, BindOutOfRangeIsAnError) {
  ASSERT_OK_AND_ASSIGN(Connection connection, Connection::Open(":memory:"));
  ASSERT_OK_AND_ASSIGN(Statement select, connection.Prepare("SELECT ?"));
  EXPECT_OK(select.BindInt64(1, 7));
  EXPECT_FALSE(select.BindInt64(2, 7).ok());
  EXPECT_FALSE(select.BindInt64(0, 7).ok());
}

TEST(StatementTest, ResetAllowsReuseWithNewBindings) {
  ASSERT_OK_AND_ASSIGN(Connection connection, Connection::Open(":memory:"));
  ASSERT_OK(connection.Exec("CREATE TABLE t (x INTEGER)"));
  ASSERT_OK_AND_ASSIGN(Statement insert, connection.Prepare("INSERT INTO t VALUES (?)"));
  for (int i = 0; i < 3; ++i) {
    insert.Reset();
    ASSERT_OK(insert.BindInt64(1, i));
    ASSERT_OK(insert.Run());
  }
  EXPECT_EQ(QueryText(connection, "SELECT group_concat(x) FROM t"), "0,1,2");
}

TEST(StatementTest, RunRefusesStatementsThatReturnRows) {
  ASSERT_OK_AND_ASSIGN(Connection connection, Connection::Open(":memory:"));
  ASSERT_OK_AND_ASSIGN(Statement select, connection.Prepare("SELECT 1"));
  EXPECT_EQ(select.Run().code(), absl::StatusCode::kInternal);
}

TEST(TransactionTest, RollsBackUnlessCommitted) {
  ASSERT_OK_AND_ASSIGN(Connection connection, Connection::Open(":memory:"));
  ASSERT_OK(connection.Exec("CREATE TABLE t (x INTEGER)"));
  {
    ASSERT_OK_AND_ASSIGN(Transaction txn, Transaction::Begin(connection));
    EXPECT_FALSE(connection.AutoCommit());
    ASSERT_OK(connection.Exec("INSERT INTO t VALUES (1)"));
  }
  EXPECT_TRUE(connection.AutoCommit());
  EXPECT_EQ(CountRows(connection, "t"), 0);

  {
    ASSERT_OK_AND_ASSIGN(Transaction txn, Transaction::Begin(connection));
    ASSERT_OK(connection.Exec("INSERT INTO t VALUES (1)"));
    ASSERT_OK(txn.Commit());
    EXPECT_EQ(txn.Commit().code(), absl::StatusCode::kFailedPrecondition);
  }
  EXPECT_EQ(CountRows(connection, "t"), 1);
}

TEST(TransactionTest, MovedTransactionRollsBackOnce) {
  ASSERT_OK_AND_ASSIGN(Connection connection, Connection::Open(":memory:"));
  ASSERT_OK(connection.Exec("CREATE TABLE t (x INTEGER)"));
  {
    ASSERT_OK_AND_ASSIGN(Transaction first, Transaction::Begin(connection));
    ASSERT_OK(connection.Exec("INSERT INTO t VALUES (1)"));
    Transaction second = std::move(first);
    ASSERT_OK(second.Commit());
  }  // `first` must not roll back the committed work
  EXPECT_EQ(CountRows(connection, "t"), 1);
}

TEST(TransactionTest, NestedBeginFails) {
  ASSERT_OK_AND_ASSIGN(Connection connection, Connection::Open(":memory:"));
  ASSERT_OK_AND_ASSIGN(Transaction txn, Transaction::Begin(connection));
  absl::StatusOr<Transaction> nested = Transaction::Begin(connection);
  EXPECT_EQ(nested.status().code(), absl::StatusCode::kInternal);
}

TEST(WalTest, SecondConnectionSeesCommittedWritesAndReadersDoNotBlockTheWriter) {
  TempDir dir;
  ASSERT_OK_AND_ASSIGN(Connection writer, Connection::Open(dir.File("shared.db")));
  ASSERT_OK_AND_ASSIGN(Connection reader, Connection::Open(dir.File("shared.db")));
  ASSERT_OK(writer.Exec("CREATE TABLE t (x INTEGER); INSERT INTO t VALUES (1), (2)"));
  EXPECT_EQ(CountRows(reader, "t"), 2);

  // The reader stays in the middle of a query (an open read snapshot) while the writer commits.
  ASSERT_OK_AND_ASSIGN(Statement scan, reader.Prepare("SELECT x FROM t ORDER BY x"));
  ASSERT_OK_AND_ASSIGN(StepResult step, scan.Step());
  ASSERT_EQ(step, StepResult::kRow);
  {
    ASSERT_OK_AND_ASSIGN(Transaction txn, Transaction::Begin(writer));
    ASSERT_OK(writer.Exec("INSERT INTO t VALUES (3)"));
    ASSERT_OK(txn.Commit());  // would be SQLITE_BUSY in rollback-journal mode
  }
  // The open snapshot does not change under the reader...
  int rows = 1;
  while (true) {
    ASSERT_OK_AND_ASSIGN(step, scan.Step());
    if (step == StepResult::kDone) break;
    ++rows;
  }
  EXPECT_EQ(rows, 2);
  // ...and the next query sees the commit.
  EXPECT_EQ(CountRows(reader, "t"), 3);
}

// One writer at a time: a second connection waits for the busy timeout, then gets UNAVAILABLE
// (transient: retry), not INTERNAL, and nothing of its transaction is written.
TEST(WalTest, WriterLockedOutPastTheBusyTimeoutIsUnavailable) {
  TempDir dir;
  ASSERT_OK_AND_ASSIGN(Connection first, Connection::Open(dir.File("shared.db")));
  ASSERT_OK_AND_ASSIGN(Connection second, Connection::Open(dir.File("shared.db")));
  ASSERT_OK(first.Exec("CREATE TABLE t (x INTEGER)"));
  sqlite3_busy_timeout(second.raw(), 50);  // the test need not wait the real 5 s
  ASSERT_OK_AND_ASSIGN(Transaction holding, Transaction::Begin(first));
  absl::StatusOr<Transaction> refused = Transaction::Begin(second);
  EXPECT_EQ(refused.status().code(), absl::StatusCode::kUnavailable) << refused.status();
  EXPECT_NE(refused.status().message().find("retry"), std::string::npos) << refused.status();
  EXPECT_EQ(second.Exec("INSERT INTO t VALUES (1)").code(), absl::StatusCode::kUnavailable);
  ASSERT_OK(holding.Commit());
  EXPECT_EQ(CountRows(second, "t"), 0);
  ASSERT_OK(second.Exec("INSERT INTO t VALUES (1)"));  // free again
  EXPECT_EQ(CountRows(first, "t"), 1);
}

}  // namespace
}  // namespace waymark::storage::sqlite
