#ifndef WAYMARK_STORAGE_POSTGRES_PG_H_
#define WAYMARK_STORAGE_POSTGRES_PG_H_

// A small layer over libpq for the PostgreSQL stores (issue 19), the counterpart of sqlite.h: it
// owns connections and results and turns libpq's outcomes into absl::Status; it knows nothing of
// the schema. No exceptions.
//
// - Every statement is sent with the extended protocol, prepared once per connection (the SQL
//   text is the cache key) and executed with binary parameters and binary results, so blobs
//   travel as raw bytes (bytea) and doubles bit-exact.
// - Errors are mapped by SQLSTATE as the SQLite layer maps its codes: a lost or refused connection,
//   a server shutting down or out of connections -> UNAVAILABLE; a serialization failure or
//   deadlock -> ABORTED (Pool::Transaction retries those); disk full -> RESOURCE_EXHAUSTED; a
//   unique violation -> ALREADY_EXISTS when the caller says that is what it means; INTERNAL else.
// - A connection URI may carry a password; it is never put in a message (RedactUri).
//
// Thread safety: a Connection is used by one thread at a time (the Pool hands each out to one
// caller); the Pool is thread-safe.

#include <libpq-fe.h>

#include <chrono>
#include <condition_variable>
#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <unordered_map>
#include <utility>
#include <vector>

#include "absl/status/status.h"
#include "absl/status/statusor.h"
#include "absl/strings/string_view.h"

namespace waymark::storage::pg {

// How a UNIQUE / PRIMARY KEY violation is reported (as sqlite::UniqueViolation).
enum class UniqueViolation { kInternal, kAlreadyExists };

// True for "postgresql://..." and "postgres://..." (libpq's URI schemes).
bool IsPostgresUri(absl::string_view text);

// The URI with any password replaced by "***", for messages and logs.
std::string RedactUri(absl::string_view uri);
// True when the URI carries a password (user:password@ or password=).
inline bool UriHasPassword(absl::string_view uri) { return RedactUri(uri) != uri; }

// Parameters of one statement ($1, $2, ... in order), sent in binary with their types.
class Params {
 public:
  Params& Int64(int64_t value);
  Params& Int32(int32_t value);
  Params& Double(double value);
  Params& OptionalDouble(const std::optional<double>& value);
  Params& Text(absl::string_view text);
  Params& Bytes(const void* data, size_t size);
  Params& Bytes(absl::string_view bytes) { return Bytes(bytes.data(), bytes.size()); }
  Params& Bytes(const std::vector<uint8_t>& bytes) { return Bytes(bytes.data(), bytes.size()); }
  // Raw float32 array in host (little-endian) byte order, as the SQLite stores keep them.
  Params& Floats(const std::vector<float>& values);
  // NULL for an empty string: the optional blob columns use NULL for "none".
  Params& OptionalBytes(const std::string& bytes);
  // A NULL of the given type (e.g. Null(kBytea)).
  Params& Null(Oid type);
  // One-dimensional arrays, so that one statement can write many rows
  // (INSERT ... SELECT ... FROM unnest($1, $2, ...)). A nullopt element is a NULL.
  Params& Int64Array(const std::vector<int64_t>& values);
  Params& DoubleArray(const std::vector<double>& values);
  Params& DoubleArray(const std::vector<std::optional<double>>& values);
  Params& BytesArray(const std::vector<absl::string_view>& values);

  int size() const { return static_cast<int>(types_.size()); }

  // PostgreSQL's built-in type oids (pg_type.h), for Null().
  static constexpr Oid kBytea = 17;
  static constexpr Oid kInt8 = 20;
  static constexpr Oid kInt4 = 23;
  static constexpr Oid kText = 25;
  static constexpr Oid kFloat8 = 701;
  static constexpr Oid kByteaArray = 1001;
  static constexpr Oid kInt8Array = 1016;
  static constexpr Oid kFloat8Array = 1022;

 private:
  friend class Connection;
  Params& Add(Oid type, std::string bytes, bool null = false);

  std::vector<Oid> types_;
  std::vector<std::string> values_;
  std::vector<bool> null_;
};

// A query's rows, read in binary. Column getters take (row, column), both 0-based, and accept the
// integer types int2/int4/int8 and the float types float4/float8 interchangeably.
class Result {
 public:
  explicit Result(PGresult* result) : result_(result, &PQclear) {}

  int rows() const { return PQntuples(result_.get()); }
  // Rows changed by an INSERT/UPDATE/DELETE.
  int64_t affected() const;
  bool IsNull(int row, int column) const { return PQgetisnull(result_.get(), row, column) != 0; }
  int64_t Int64(int row, int column) const;
  int32_t Int32(int row, int column) const { return static_cast<int32_t>(Int64(row, column)); }
  double Double(int row, int column) const;
  std::optional<double> OptionalDouble(int row, int column) const;
  std::string Text(int row, int column) const { return std::string(Bytes(row, column)); }
  // Raw bytes of the value (bytea, text); valid while the Result lives. Empty for NULL.
  absl::string_view Bytes(int row, int column) const;
  std::vector<uint8_t> ByteVector(int row, int column) const;
  // A float32 blob; DATA_LOSS when its size is not a whole number of floats.
  absl::StatusOr<std::vector<float>> Floats(int row, int column) const;

 private:
  friend class Connection;
  std::unique_ptr<PGresult, void (*)(PGresult*)> result_;
};

// One libpq connection with its cache of prepared statements.
class Connection {
 public:
  // Connects (libpq URI or keyword string). UNAVAILABLE with libpq's message (password-free)
  // when the server cannot be reached or refuses.
  static absl::StatusOr<std::unique_ptr<Connection>> Open(const std::string& uri);
  ~Connection();
  Connection(const Connection&) = delete;
  Connection& operator=(const Connection&) = delete;

  // Runs one statement (prepared on first use on this connection) with `params`.
  absl::StatusOr<Result> Execute(absl::string_view sql, const Params& params = Params(),
                                 UniqueViolation on_unique = UniqueViolation::kInternal);
  // Runs SQL without parameters, possibly several statements (DDL, BEGIN/COMMIT), unprepared.
  absl::Status Script(absl::string_view sql);

  // False once the connection is lost; the pool reconnects it.
  bool healthy() const { return PQstatus(conn_) == CONNECTION_OK; }
  // Reconnects a lost connection (prepared statements are gone with it).
  absl::Status Reset();
  PGconn* raw() const { return conn_; }

 private:
  explicit Connection(PGconn* conn) : conn_(conn) {}

  PGconn* conn_;
  std::unordered_map<std::string, std::string> prepared_;  // SQL -> statement name
};

// A status for a failed call: the message is "<context>: <server message>" and the code follows
// the SQLSTATE as described at the top of this file.
absl::Status Error(const PGresult* result, PGconn* conn, absl::string_view context,
                   UniqueViolation on_unique = UniqueViolation::kInternal);

// A fixed number of connections shared by a store's callers. A caller waits (up to
// `acquire_timeout`) for a free connection; a connection found lost is reconnected before it is
// handed out, so a restarted PostgreSQL is used again without a server restart.
class Pool {
 public:
  struct Options {
    // Enough for a server's concurrent writes: each holds one connection for its database's
    // write lock (CrossingStore::LockForWriting) and uses another for its transaction.
    int size = 8;
    std::chrono::milliseconds acquire_timeout{10000};
    // How often Transaction runs its body again after a serialization failure or deadlock.
    int max_retries = 5;
  };

  static absl::StatusOr<std::unique_ptr<Pool>> Open(const std::string& uri, Options options);
  static absl::StatusOr<std::unique_ptr<Pool>> Open(const std::string& uri) {
    return Open(uri, Options());
  }

  // Runs `body` on one connection without an explicit transaction (each statement commits).
  absl::Status Run(const std::function<absl::Status(Connection&)>& body);
  // Runs `body` inside BEGIN ... COMMIT (READ COMMITTED); any error rolls it back. A body that
  // fails with ABORTED (serialization failure, deadlock) is run again, up to max_retries times,
  // so `body` must have no effects outside the transaction.
  absl::Status Transaction(const std::function<absl::Status(Connection&)>& body);

  // Run and Transaction for a body that reads something: what the body returned, once it (and
  // the commit) succeeded. T is given explicitly: pool.Run<int64_t>([&](Connection& c) {...}).
  template <typename T>
  absl::StatusOr<T> Run(const std::function<absl::StatusOr<T>(Connection&)>& body) {
    std::optional<T> value;
    absl::Status status = Run(KeepValue(body, value));
    if (!status.ok()) return status;
    return *std::move(value);
  }
  template <typename T>
  absl::StatusOr<T> Transaction(const std::function<absl::StatusOr<T>(Connection&)>& body) {
    std::optional<T> value;
    absl::Status status = Transaction(KeepValue(body, value));
    if (!status.ok()) return status;
    return *std::move(value);
  }

  // A connection held by one caller until the Lease is destroyed (e.g. for a session-level
  // advisory lock that outlives single statements); it then goes back to the pool.
  class Lease {
   public:
    Lease(Pool* pool, std::unique_ptr<Connection> connection)
        : pool_(pool), connection_(std::move(connection)) {}
    Lease(Lease&&) = default;
    Lease& operator=(Lease&&) = delete;
    ~Lease() {
      if (connection_ != nullptr) pool_->Release(std::move(connection_));
    }
    Connection& connection() { return *connection_; }

   private:
    Pool* pool_;
    std::unique_ptr<Connection> connection_;
  };
  absl::StatusOr<Lease> Hold();

  const std::string& uri() const { return uri_; }

 private:
  Pool(std::string uri, Options options) : uri_(std::move(uri)), options_(options) {}

  // `body` as a status-only body that stores its value in `value` (a retried transaction's last
  // attempt overwrites the earlier ones').
  template <typename T>
  static std::function<absl::Status(Connection&)> KeepValue(
      const std::function<absl::StatusOr<T>(Connection&)>& body, std::optional<T>& value) {
    return [&body, &value](Connection& connection) -> absl::Status {
      absl::StatusOr<T> result = body(connection);
      if (!result.ok()) return result.status();
      value = *std::move(result);
      return absl::OkStatus();
    };
  }

  absl::StatusOr<std::unique_ptr<Connection>> Acquire();
  void Release(std::unique_ptr<Connection> connection);

  const std::string uri_;
  const Options options_;
  std::mutex mutex_;
  std::condition_variable available_;
  std::vector<std::unique_ptr<Connection>> idle_;
  int open_ = 0;  // connections handed out or idle
};

}  // namespace waymark::storage::pg

#endif  // WAYMARK_STORAGE_POSTGRES_PG_H_
