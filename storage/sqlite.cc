#include "storage/sqlite.h"

#include <chrono>
#include <cstring>
#include <limits>

#include "absl/strings/str_cat.h"

namespace waymark::storage::sqlite {
namespace {

// Blobs are raw little-endian arrays copied with memcpy; refuse to build where that would be wrong
// rather than silently writing files other machines cannot read.
static_assert(__BYTE_ORDER__ == __ORDER_LITTLE_ENDIAN__,
              "blob layout assumes a little-endian host");
static_assert(sizeof(float) == 4 && std::numeric_limits<float>::is_iec559,
              "blob layout assumes IEEE-754 float32");

// The start of a statement's SQL, enough to recognise it in an error message.
std::string SqlSnippet(sqlite3_stmt* stmt) {
  constexpr size_t kMaxChars = 80;
  const char* sql = stmt != nullptr ? sqlite3_sql(stmt) : nullptr;
  if (sql == nullptr) return "?";
  std::string text(sql);
  for (char& c : text) {
    if (c == '\n' || c == '\t') c = ' ';
  }
  if (text.size() > kMaxChars) text = absl::StrCat(text.substr(0, kMaxChars), "...");
  return text;
}

}  // namespace

absl::Status Error(sqlite3* db, int rc, absl::string_view context, UniqueViolation on_unique) {
  // Read the message first: any later call on the connection may overwrite it.
  const char* message = db != nullptr ? sqlite3_errmsg(db) : sqlite3_errstr(rc);
  std::string text = absl::StrCat(context, ": ", message, " (sqlite code ", rc, ")");
  const bool unique = rc == SQLITE_CONSTRAINT_UNIQUE || rc == SQLITE_CONSTRAINT_PRIMARYKEY;
  if (unique && on_unique == UniqueViolation::kAlreadyExists) {
    return absl::AlreadyExistsError(text);
  }
  switch (rc & 0xff) {  // the primary code of an extended one
    case SQLITE_BUSY:
    case SQLITE_LOCKED:
      // Another connection (another process, or another store of this server) held the write
      // lock for the whole busy timeout. Not a bug and nothing was written: the caller may retry.
      return absl::UnavailableError(
          absl::StrCat(text, ": another writer held the database for more than ", kBusyTimeoutMs,
                       " ms; nothing was written, retry later"));
    case SQLITE_FULL:
      return absl::ResourceExhaustedError(absl::StrCat(text, ": the disk is full"));
    default:
      return absl::InternalError(text);
  }
}

// ---------------------------------------------------------------------------------------------
// Connection

namespace {

// SQLite's own busy handler (sqlite3_busy_timeout) sleeps 1, 2, 5, 10, 15, 20, 25, 25, 25, 50, 50,
// 100 ms between tries: a writer behind a 60 ms transaction got the lock after 80 ms, behind a
// 100 ms one after 105 ms (measured), so a token revocation behind a checkpoint took 80-135 ms
// (issue 21). Trying again every millisecond waits for the holder and not for the schedule; it
// gives up after kBusyTimeoutMs as before.
int RetryEveryMillisecond(void*, int tries) {
  thread_local std::chrono::steady_clock::time_point first_try;
  const auto now = std::chrono::steady_clock::now();
  if (tries == 0) first_try = now;
  if (now - first_try >= std::chrono::milliseconds(kBusyTimeoutMs)) return 0;
  sqlite3_sleep(1);
  return 1;
}

}  // namespace

absl::StatusOr<Connection> Connection::Open(const std::string& path, int flags) {
  sqlite3* db = nullptr;
  const int rc = sqlite3_open_v2(path.c_str(), &db, flags, nullptr);
  if (rc != SQLITE_OK) {
    absl::Status status = Error(db, rc, absl::StrCat("cannot open \"", path, "\""));
    sqlite3_close_v2(db);  // SQLite allocates a handle even when opening fails
    return status;
  }
  // Extended codes let Error() tell a UNIQUE violation from other constraint failures.
  sqlite3_extended_result_codes(db, 1);
  sqlite3_busy_handler(db, RetryEveryMillisecond, nullptr);

  Connection connection(db, path);
  // A read-only handle cannot switch the journal mode; it follows whatever the file uses.
  if ((flags & SQLITE_OPEN_READONLY) == 0) {
    if (absl::Status s = connection.Exec("PRAGMA journal_mode=WAL"); !s.ok()) return s;
  }
  if (absl::Status s = connection.Exec("PRAGMA foreign_keys=ON"); !s.ok()) return s;
  if (absl::Status s = connection.Exec("PRAGMA synchronous=NORMAL"); !s.ok()) return s;
  return connection;
}

Connection::Connection(Connection&& other) noexcept
    : db_(std::exchange(other.db_, nullptr)), path_(std::move(other.path_)) {}

Connection& Connection::operator=(Connection&& other) noexcept {
  if (this != &other) {
    sqlite3_close_v2(db_);
    db_ = std::exchange(other.db_, nullptr);
    path_ = std::move(other.path_);
  }
  return *this;
}

// close_v2 (not close) so that a statement outliving its connection by mistake delays the close
// instead of leaking the handle.
Connection::~Connection() { sqlite3_close_v2(db_); }

absl::Status Connection::Exec(absl::string_view sql) {
  const std::string text(sql);  // sqlite3_exec wants a NUL-terminated string
  const int rc = sqlite3_exec(db_, text.c_str(), nullptr, nullptr, nullptr);
  if (rc != SQLITE_OK) return Error(db_, rc, absl::StrCat("exec \"", text.substr(0, 80), "\""));
  return absl::OkStatus();
}

absl::StatusOr<Statement> Connection::Prepare(absl::string_view sql) {
  sqlite3_stmt* stmt = nullptr;
  const char* tail = nullptr;
  const int rc = sqlite3_prepare_v2(db_, sql.data(), static_cast<int>(sql.size()), &stmt, &tail);
  if (rc != SQLITE_OK) {
    return Error(db_, rc, absl::StrCat("prepare \"", sql.substr(0, 80), "\""));
  }
  Statement statement(stmt);
  if (stmt == nullptr) {
    return absl::InternalError(absl::StrCat("prepare: no SQL statement in \"", sql, "\""));
  }
  // Anything after the first statement would be silently ignored by SQLite: refuse it.
  const absl::string_view rest = sql.substr(static_cast<size_t>(tail - sql.data()));
  if (rest.find_first_not_of(" \t\r\n;") != absl::string_view::npos) {
    return absl::InternalError(
        absl::StrCat("prepare: more than one statement in \"", sql.substr(0, 80), "\""));
  }
  return statement;
}

int64_t Connection::LastInsertRowId() const { return sqlite3_last_insert_rowid(db_); }

int64_t Connection::Changes() const { return sqlite3_changes64(db_); }

bool Connection::AutoCommit() const { return sqlite3_get_autocommit(db_) != 0; }

// ---------------------------------------------------------------------------------------------
// Statement

Statement::Statement(Statement&& other) noexcept : stmt_(std::exchange(other.stmt_, nullptr)) {}

Statement& Statement::operator=(Statement&& other) noexcept {
  if (this != &other) {
    sqlite3_finalize(stmt_);
    stmt_ = std::exchange(other.stmt_, nullptr);
  }
  return *this;
}

Statement::~Statement() { sqlite3_finalize(stmt_); }

absl::Status Statement::BindResult(int rc, int index) const {
  if (rc == SQLITE_OK) return absl::OkStatus();
  return Error(sqlite3_db_handle(stmt_), rc,
               absl::StrCat("bind ?", index, " of \"", SqlSnippet(stmt_), "\""));
}

absl::Status Statement::BindNull(int index) {
  return BindResult(sqlite3_bind_null(stmt_, index), index);
}

absl::Status Statement::BindInt64(int index, int64_t value) {
  return BindResult(sqlite3_bind_int64(stmt_, index, value), index);
}

absl::Status Statement::BindDouble(int index, double value) {
  return BindResult(sqlite3_bind_double(stmt_, index, value), index);
}

absl::Status Statement::BindOptionalDouble(int index, const std::optional<double>& value) {
  return value.has_value() ? BindDouble(index, *value) : BindNull(index);
}

absl::Status Statement::BindText(int index, absl::string_view text) {
  // A null data pointer would bind NULL; an empty string_view may carry one.
  const char* data = text.data() != nullptr ? text.data() : "";
  return BindResult(
      sqlite3_bind_text64(stmt_, index, data, text.size(), SQLITE_TRANSIENT, SQLITE_UTF8), index);
}

absl::Status Statement::BindBlob(int index, const void* data, size_t size) {
  // sqlite3_bind_blob with a null pointer binds NULL, and an empty vector's data() may be null:
  // bind an explicit zero-length blob so that "no keypoints" reads back as empty, not NULL.
  if (size == 0) return BindResult(sqlite3_bind_zeroblob(stmt_, index, 0), index);
  return BindResult(sqlite3_bind_blob64(stmt_, index, data, size, SQLITE_TRANSIENT), index);
}

absl::Status Statement::BindBlob(int index, const std::vector<uint8_t>& bytes) {
  return BindBlob(index, bytes.data(), bytes.size());
}

absl::Status Statement::BindBlob(int index, const std::vector<float>& values) {
  return BindBlob(index, values.data(), values.size() * sizeof(float));
}

absl::StatusOr<StepResult> Statement::Step(UniqueViolation on_unique) {
  const int rc = sqlite3_step(stmt_);
  if (rc == SQLITE_ROW) return StepResult::kRow;
  if (rc == SQLITE_DONE) return StepResult::kDone;
  return Error(sqlite3_db_handle(stmt_), rc, absl::StrCat("step \"", SqlSnippet(stmt_), "\""),
               on_unique);
}

absl::Status Statement::Run(UniqueViolation on_unique) {
  absl::StatusOr<StepResult> result = Step(on_unique);
  if (!result.ok()) return result.status();
  if (*result != StepResult::kDone) {
    return absl::InternalError(
        absl::StrCat("statement \"", SqlSnippet(stmt_), "\" returned rows; use Step()"));
  }
  return absl::OkStatus();
}

// sqlite3_reset repeats the error of the last failed step, which Step() already reported, so its
// result carries no new information.
void Statement::Reset() { sqlite3_reset(stmt_); }

void Statement::ClearBindings() { sqlite3_clear_bindings(stmt_); }

int Statement::ColumnCount() const { return sqlite3_column_count(stmt_); }

bool Statement::ColumnIsNull(int column) const {
  return sqlite3_column_type(stmt_, column) == SQLITE_NULL;
}

int64_t Statement::ColumnInt64(int column) const { return sqlite3_column_int64(stmt_, column); }

int32_t Statement::ColumnInt32(int column) const { return sqlite3_column_int(stmt_, column); }

double Statement::ColumnDouble(int column) const { return sqlite3_column_double(stmt_, column); }

std::optional<double> Statement::ColumnOptionalDouble(int column) const {
  if (ColumnIsNull(column)) return std::nullopt;
  return ColumnDouble(column);
}

std::string Statement::ColumnText(int column) const {
  // text before bytes: sqlite3_column_bytes reports the size of the representation last asked for.
  const unsigned char* text = sqlite3_column_text(stmt_, column);
  const int size = sqlite3_column_bytes(stmt_, column);
  if (text == nullptr) return std::string();
  return std::string(reinterpret_cast<const char*>(text), static_cast<size_t>(size));
}

absl::string_view Statement::ColumnBlobView(int column) const {
  const void* data = sqlite3_column_blob(stmt_, column);
  const int size = sqlite3_column_bytes(stmt_, column);
  if (data == nullptr) return absl::string_view();
  return absl::string_view(static_cast<const char*>(data), static_cast<size_t>(size));
}

std::vector<uint8_t> Statement::ColumnBlob(int column) const {
  const absl::string_view bytes = ColumnBlobView(column);
  return std::vector<uint8_t>(bytes.begin(), bytes.end());
}

absl::StatusOr<std::vector<float>> Statement::ColumnFloatBlob(int column) const {
  const absl::string_view bytes = ColumnBlobView(column);
  if (bytes.size() % sizeof(float) != 0) {
    return absl::DataLossError(absl::StrCat("column ", sqlite3_column_name(stmt_, column), " has ",
                                            bytes.size(), " bytes, not a whole number of floats"));
  }
  std::vector<float> values(bytes.size() / sizeof(float));
  if (!bytes.empty()) std::memcpy(values.data(), bytes.data(), bytes.size());
  return values;
}

// ---------------------------------------------------------------------------------------------
// Transaction

absl::StatusOr<Transaction> Transaction::Begin(Connection& connection) {
  if (absl::Status s = connection.Exec("BEGIN IMMEDIATE"); !s.ok()) return s;
  return Transaction(&connection);
}

Transaction::Transaction(Transaction&& other) noexcept
    : connection_(std::exchange(other.connection_, nullptr)) {}

Transaction::~Transaction() {
  // Some errors (SQLITE_FULL, IOERR, ...) already rolled the transaction back; ROLLBACK would then
  // fail with "no transaction is active", so only issue it while one is open.
  if (connection_ != nullptr && !connection_->AutoCommit()) {
    connection_->Exec("ROLLBACK").IgnoreError();
  }
}

absl::Status Transaction::Commit() {
  if (connection_ == nullptr) {
    return absl::FailedPreconditionError("transaction already committed");
  }
  if (absl::Status s = connection_->Exec("COMMIT"); !s.ok()) return s;
  connection_ = nullptr;
  return absl::OkStatus();
}

}  // namespace waymark::storage::sqlite
