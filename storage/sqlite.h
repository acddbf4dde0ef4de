#ifndef WAYMARK_STORAGE_SQLITE_H_
#define WAYMARK_STORAGE_SQLITE_H_

// A small RAII layer over the SQLite C API, shared by every SQLite-backed store (crossings now,
// SLAM sessions later, in the same file). It owns handles and turns result codes into absl::Status;
// it knows nothing about the schema. No exceptions: every fallible call returns a status whose
// message carries SQLite's own text (sqlite3_errmsg).
//
// Thread safety: none of these objects are thread-safe. A store guards its Connection with a mutex
// (SQLite has a single writer per file anyway, and sqlite3_errmsg is per connection).

#include <sqlite3.h>

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace waymark::storage::sqlite {

// Open flags used when the caller gives none: read-write, create the file if missing.
inline constexpr int kDefaultOpenFlags = SQLITE_OPEN_READWRITE | SQLITE_OPEN_CREATE;
// How long a connection waits for another connection's write lock before giving up.
inline constexpr int kBusyTimeoutMs = 5000;

// What Step() found.
enum class StepResult { kRow, kDone };

// How a UNIQUE / PRIMARY KEY violation is reported. Only the caller knows whether it means
// "the client asked for a name that is taken" (ALREADY_EXISTS) or a bug (INTERNAL).
enum class UniqueViolation { kInternal, kAlreadyExists };

class Statement;

// One open database handle, configured for a concurrent server: WAL (readers never block the
// writer), foreign keys enforced (the schema relies on ON DELETE CASCADE), a 5 s busy timeout,
// synchronous=NORMAL (durable across process crashes; in WAL only a power loss can drop the last
// commits, never corrupt the file).
class Connection {
 public:
  // Opens `path` (":memory:" for a private in-memory database) and applies the pragmas above.
  static absl::StatusOr<Connection> Open(const std::string& path, int flags = kDefaultOpenFlags);

  Connection(Connection&& other) noexcept;
  Connection& operator=(Connection&& other) noexcept;
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;
  ~Connection();

  // Runs one or more statements that return no rows the caller needs (DDL, pragmas).
  absl::Status Exec(absl::string_view sql);
  // Compiles exactly one statement.
  absl::StatusOr<Statement> Prepare(absl::string_view sql);

  // Rowid of the last successful INSERT on this connection.
  int64_t LastInsertRowId() const;
  // Rows changed by the last INSERT/UPDATE/DELETE (not counting cascades).
  int64_t Changes() const;
  // True when no transaction is open.
  bool AutoCommit() const;

  const std::string& path() const { return path_; }
  // The raw handle, for the rare call this wrapper does not cover.
  sqlite3* raw() const { return db_; }

 private:
  Connection(sqlite3* db, std::string path) : db_(db), path_(std::move(path)) {}

  sqlite3* db_ = nullptr;
  std::string path_;
};

// A prepared statement. Bind indexes are 1-based, column indexes 0-based (as in SQLite).
// Bound text and blobs are copied, so the caller's buffers may die right after the Bind call.
class Statement {
 public:
  Statement(Statement&& other) noexcept;
  Statement& operator=(Statement&& other) noexcept;
  Statement(const Statement&) = delete;
  Statement& operator=(const Statement&) = delete;
  ~Statement();

  absl::Status BindNull(int index);
  absl::Status BindInt64(int index, int64_t value);
  absl::Status BindDouble(int index, double value);
  // NULL for nullopt.
  absl::Status BindOptionalDouble(int index, const std::optional<double>& value);
  absl::Status BindText(int index, absl::string_view text);
  // An empty blob is stored as a zero-length blob, not as NULL.
  absl::Status BindBlob(int index, const void* data, size_t size);
  absl::Status BindBlob(int index, const std::vector<uint8_t>& bytes);
  // Raw float32 array in host (little-endian) byte order.
  absl::Status BindBlob(int index, const std::vector<float>& values);

  // Advances to the next row, or reports that the statement is done.
  absl::StatusOr<StepResult> Step(UniqueViolation on_unique = UniqueViolation::kInternal);
  // Steps a statement that must not return rows (INSERT/UPDATE/DELETE) to completion.
  absl::Status Run(UniqueViolation on_unique = UniqueViolation::kInternal);
  // Makes the statement ready to step again; bindings are kept (ClearBindings drops them).
  void Reset();
  void ClearBindings();

  int ColumnCount() const;
  bool ColumnIsNull(int column) const;
  int64_t ColumnInt64(int column) const;
  int32_t ColumnInt32(int column) const;
  double ColumnDouble(int column) const;
  // nullopt for NULL.
  std::optional<double> ColumnOptionalDouble(int column) const;
  std::string ColumnText(int column) const;
  // Blob bytes; valid until the next Step/Reset/destruction. Empty for NULL.
  absl::string_view ColumnBlobView(int column) const;
  std::vector<uint8_t> ColumnBlob(int column) const;
  // A float32 blob; DATA_LOSS when its size is not a whole number of floats.
  absl::StatusOr<std::vector<float>> ColumnFloatBlob(int column) const;

  sqlite3_stmt* raw() const { return stmt_; }

 private:
  friend class Connection;
  explicit Statement(sqlite3_stmt* stmt) : stmt_(stmt) {}

  absl::Status BindResult(int rc, int index) const;

  sqlite3_stmt* stmt_ = nullptr;
};

// BEGIN IMMEDIATE ... COMMIT. IMMEDIATE takes the write lock up front so that two writers never
// deadlock upgrading a read lock (which busy_timeout cannot resolve). Rolls back in the destructor
// unless Commit() succeeded, so an early `return status;` undoes everything.
class Transaction {
 public:
  static absl::StatusOr<Transaction> Begin(Connection& connection);

  Transaction(Transaction&& other) noexcept;
  Transaction& operator=(Transaction&&) = delete;
  Transaction(const Transaction&) = delete;
  Transaction& operator=(const Transaction&) = delete;
  ~Transaction();

  absl::Status Commit();

 private:
  explicit Transaction(Connection* connection) : connection_(connection) {}

  Connection* connection_;  // null once committed or moved from
};

// A status for a failed SQLite call, message "<context>: <sqlite3_errmsg> (<extended code>)":
// ALREADY_EXISTS for a unique violation when asked; UNAVAILABLE when the database stayed locked by
// another writer for the whole busy timeout (transient, nothing written); RESOURCE_EXHAUSTED when
// the disk is full; INTERNAL otherwise.
absl::Status Error(sqlite3* db, int rc, absl::string_view context,
                   UniqueViolation on_unique = UniqueViolation::kInternal);

}  // namespace waymark::storage::sqlite

#endif  // WAYMARK_STORAGE_SQLITE_H_
