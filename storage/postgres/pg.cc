#include "storage/postgres/pg.h"

#include <endian.h>

#include <cstring>
#include <thread>

#include "absl/strings/match.h"
#include "absl/strings/str_cat.h"
#include "absl/strings/strip.h"

namespace waymark::storage::pg {
namespace {

// float4, which Result::Double also reads (pg_type.h).
constexpr Oid kFloat4 = 700;

std::string BigEndian64(uint64_t host) {
  const uint64_t be = htobe64(host);
  return std::string(reinterpret_cast<const char*>(&be), sizeof(be));
}

// float8's binary format: the IEEE 754 bits, big-endian.
std::string DoubleBytes(double value) {
  uint64_t bits;
  std::memcpy(&bits, &value, sizeof(bits));
  return BigEndian64(bits);
}

// PostgreSQL's binary format of a one-dimensional array (array_send / array_recv): the number of
// dimensions, whether any element is NULL, the element type; the dimension's length and lower
// bound (1); then each element as its length (-1 for NULL) and its binary value.
class ArrayBytes {
 public:
  ArrayBytes(Oid element_type, size_t count, bool has_null) {
    Append32(1);
    Append32(has_null ? 1 : 0);
    Append32(element_type);
    Append32(static_cast<uint32_t>(count));
    Append32(1);
  }

  void Element(absl::string_view value) {
    Append32(static_cast<uint32_t>(value.size()));
    bytes_.append(value.data(), value.size());
  }
  void Null() { Append32(static_cast<uint32_t>(-1)); }

  std::string Take() && { return std::move(bytes_); }

 private:
  void Append32(uint32_t host) {
    const uint32_t be = htobe32(host);
    bytes_.append(reinterpret_cast<const char*>(&be), sizeof(be));
  }

  std::string bytes_;
};

// The start of a statement, to say in a message which one failed.
std::string Describe(absl::string_view sql) {
  constexpr size_t kShown = 60;
  std::string text(sql.substr(0, kShown));
  for (char& c : text) {
    if (c == '\n') c = ' ';
  }
  return sql.size() > kShown ? absl::StrCat(text, "...") : text;
}

// libpq's notices (e.g. "relation already exists, skipping") are not errors; the stores do not
// print them.
void IgnoreNotice(void*, const char*) {}

}  // namespace

bool IsPostgresUri(absl::string_view text) {
  return absl::StartsWith(text, "postgresql://") || absl::StartsWith(text, "postgres://");
}

std::string RedactUri(absl::string_view uri) {
  // scheme://[user[:password]@]host...: the password is between the first ':' after the scheme
  // and the '@' that ends the user info. A "password=" query parameter is cut the same way.
  std::string out(uri);
  const size_t scheme = out.find("://");
  if (scheme != std::string::npos) {
    const size_t start = scheme + 3;
    const size_t at = out.find('@', start);
    const size_t slash = out.find('/', start);
    if (at != std::string::npos && (slash == std::string::npos || at < slash)) {
      const size_t colon = out.find(':', start);
      if (colon != std::string::npos && colon < at) out.replace(colon + 1, at - colon - 1, "***");
    }
  }
  for (size_t p = out.find("password="); p != std::string::npos; p = out.find("password=", p + 1)) {
    const size_t value = p + std::strlen("password=");
    size_t end = out.find_first_of("& ", value);
    if (end == std::string::npos) end = out.size();
    out.replace(value, end - value, "***");
  }
  return out;
}

Params& Params::Add(Oid type, std::string bytes, bool null) {
  types_.push_back(type);
  values_.push_back(std::move(bytes));
  null_.push_back(null);
  return *this;
}

Params& Params::Int64(int64_t value) {
  return Add(kInt8, BigEndian64(static_cast<uint64_t>(value)));
}

Params& Params::Int32(int32_t value) {
  const uint32_t be = htobe32(static_cast<uint32_t>(value));
  return Add(kInt4, std::string(reinterpret_cast<const char*>(&be), sizeof(be)));
}

Params& Params::Double(double value) { return Add(kFloat8, DoubleBytes(value)); }

Params& Params::OptionalDouble(const std::optional<double>& value) {
  return value ? Double(*value) : Null(kFloat8);
}

Params& Params::Text(absl::string_view text) { return Add(kText, std::string(text)); }

Params& Params::Bytes(const void* data, size_t size) {
  return Add(kBytea, std::string(static_cast<const char*>(data), size));
}

Params& Params::Floats(const std::vector<float>& values) {
  return Bytes(values.data(), values.size() * sizeof(float));
}

Params& Params::OptionalBytes(const std::string& bytes) {
  return bytes.empty() ? Null(kBytea) : Bytes(bytes);
}

Params& Params::Null(Oid type) { return Add(type, std::string(), true); }

Params& Params::Int64Array(const std::vector<int64_t>& values) {
  ArrayBytes array(kInt8, values.size(), /*has_null=*/false);
  for (int64_t value : values) array.Element(BigEndian64(static_cast<uint64_t>(value)));
  return Add(kInt8Array, std::move(array).Take());
}

Params& Params::DoubleArray(const std::vector<double>& values) {
  ArrayBytes array(kFloat8, values.size(), /*has_null=*/false);
  for (double value : values) array.Element(DoubleBytes(value));
  return Add(kFloat8Array, std::move(array).Take());
}

Params& Params::DoubleArray(const std::vector<std::optional<double>>& values) {
  bool has_null = false;
  for (const std::optional<double>& value : values) has_null = has_null || !value.has_value();
  ArrayBytes array(kFloat8, values.size(), has_null);
  for (const std::optional<double>& value : values) {
    if (value.has_value()) {
      array.Element(DoubleBytes(*value));
    } else {
      array.Null();
    }
  }
  return Add(kFloat8Array, std::move(array).Take());
}

Params& Params::BytesArray(const std::vector<absl::string_view>& values) {
  ArrayBytes array(kBytea, values.size(), /*has_null=*/false);
  for (absl::string_view value : values) array.Element(value);
  return Add(kByteaArray, std::move(array).Take());
}

int64_t Result::affected() const {
  const char* tuples = PQcmdTuples(result_.get());
  return tuples[0] == '\0' ? 0 : std::strtoll(tuples, nullptr, 10);
}

int64_t Result::Int64(int row, int column) const {
  const char* value = PQgetvalue(result_.get(), row, column);
  switch (PQgetlength(result_.get(), row, column)) {
    case 8: {
      uint64_t be;
      std::memcpy(&be, value, 8);
      return static_cast<int64_t>(be64toh(be));
    }
    case 4: {
      uint32_t be;
      std::memcpy(&be, value, 4);
      return static_cast<int32_t>(be32toh(be));
    }
    case 2: {
      uint16_t be;
      std::memcpy(&be, value, 2);
      return static_cast<int16_t>(be16toh(be));
    }
    default:
      return 0;  // NULL
  }
}

double Result::Double(int row, int column) const {
  // A NULL's value is an empty string: reading 4 or 8 bytes from it would overrun it.
  if (IsNull(row, column)) return 0;
  const char* value = PQgetvalue(result_.get(), row, column);
  if (PQftype(result_.get(), column) == kFloat4) {
    uint32_t be;
    std::memcpy(&be, value, 4);
    const uint32_t bits = be32toh(be);
    float f;
    std::memcpy(&f, &bits, 4);
    return f;
  }
  if (PQftype(result_.get(), column) != Params::kFloat8)
    return static_cast<double>(Int64(row, column));
  uint64_t be;
  std::memcpy(&be, value, 8);
  const uint64_t bits = be64toh(be);
  double d;
  std::memcpy(&d, &bits, 8);
  return d;
}

std::optional<double> Result::OptionalDouble(int row, int column) const {
  if (IsNull(row, column)) return std::nullopt;
  return Double(row, column);
}

absl::string_view Result::Bytes(int row, int column) const {
  return absl::string_view(PQgetvalue(result_.get(), row, column),
                           static_cast<size_t>(PQgetlength(result_.get(), row, column)));
}

std::vector<uint8_t> Result::ByteVector(int row, int column) const {
  const absl::string_view bytes = Bytes(row, column);
  return std::vector<uint8_t>(bytes.begin(), bytes.end());
}

absl::StatusOr<std::vector<float>> Result::Floats(int row, int column) const {
  const absl::string_view bytes = Bytes(row, column);
  if (bytes.size() % sizeof(float) != 0) {
    return absl::DataLossError(
        absl::StrCat("a float array of ", bytes.size(), " bytes is not a whole number of floats"));
  }
  std::vector<float> values(bytes.size() / sizeof(float));
  if (!values.empty()) std::memcpy(values.data(), bytes.data(), bytes.size());
  return values;
}

absl::Status Error(const PGresult* result, PGconn* conn, absl::string_view context,
                   UniqueViolation on_unique) {
  std::string message = result != nullptr ? PQresultErrorMessage(result) : PQerrorMessage(conn);
  absl::string_view trimmed = absl::StripTrailingAsciiWhitespace(message);
  if (absl::ConsumePrefix(&trimmed, "ERROR:")) trimmed = absl::StripLeadingAsciiWhitespace(trimmed);
  const std::string text = absl::StrCat(context, ": ", trimmed);
  const char* sqlstate = result != nullptr ? PQresultErrorField(result, PG_DIAG_SQLSTATE) : nullptr;
  if (sqlstate == nullptr || PQstatus(conn) != CONNECTION_OK) {
    return absl::UnavailableError(absl::StrCat(text, " (the connection to PostgreSQL is lost)"));
  }
  const absl::string_view state(sqlstate);
  if (state == "23505") {
    return on_unique == UniqueViolation::kAlreadyExists ? absl::AlreadyExistsError(text)
                                                        : absl::InternalError(text);
  }
  if (state == "40001" || state == "40P01") return absl::AbortedError(text);
  if (state == "53100")
    return absl::ResourceExhaustedError(absl::StrCat(text, ": the disk is full"));
  // Connection exceptions, the server shutting down or starting, too many connections, a
  // read-only standby, a lock wait past lock_timeout: transient, nothing was written.
  if (absl::StartsWith(state, "08") || absl::StartsWith(state, "57P") ||
      absl::StartsWith(state, "53") || state == "25006" || state == "55P03") {
    return absl::UnavailableError(text);
  }
  return absl::InternalError(absl::StrCat(text, " (SQLSTATE ", state, ")"));
}

absl::StatusOr<std::unique_ptr<Connection>> Connection::Open(const std::string& uri) {
  // connect_timeout before dbname: a value in the URI overrides it.
  const char* keywords[] = {"connect_timeout", "application_name", "dbname", nullptr};
  const char* values[] = {"10", "waymark", uri.c_str(), nullptr};
  PGconn* conn = PQconnectdbParams(keywords, values, /*expand_dbname=*/1);
  if (conn == nullptr) return absl::ResourceExhaustedError("libpq could not allocate a connection");
  if (PQstatus(conn) != CONNECTION_OK) {
    const std::string message(absl::StripTrailingAsciiWhitespace(PQerrorMessage(conn)));
    PQfinish(conn);
    return absl::UnavailableError(
        absl::StrCat("cannot connect to PostgreSQL at ", RedactUri(uri), ": ", message));
  }
  PQsetNoticeProcessor(conn, &IgnoreNotice, nullptr);
  return std::unique_ptr<Connection>(new Connection(conn));
}

Connection::~Connection() { PQfinish(conn_); }

absl::Status Connection::Reset() {
  prepared_.clear();
  PQreset(conn_);
  if (PQstatus(conn_) != CONNECTION_OK) {
    return absl::UnavailableError(
        absl::StrCat("cannot reconnect to PostgreSQL: ",
                     absl::StripTrailingAsciiWhitespace(PQerrorMessage(conn_))));
  }
  PQsetNoticeProcessor(conn_, &IgnoreNotice, nullptr);
  return absl::OkStatus();
}

absl::StatusOr<Result> Connection::Execute(absl::string_view sql, const Params& params,
                                           UniqueViolation on_unique) {
  const std::string key(sql);
  auto it = prepared_.find(key);
  if (it == prepared_.end()) {
    const std::string name = absl::StrCat("waymark_", prepared_.size());
    Result prepared(
        PQprepare(conn_, name.c_str(), key.c_str(), params.size(), params.types_.data()));
    // A null PGresult (out of memory, connection gone) reads as a fatal status.
    if (PQresultStatus(prepared.result_.get()) != PGRES_COMMAND_OK) {
      return Error(prepared.result_.get(), conn_, absl::StrCat("preparing ", Describe(sql)));
    }
    it = prepared_.emplace(key, name).first;
  }
  const int n = params.size();
  std::vector<const char*> values(n);
  std::vector<int> lengths(n);
  std::vector<int> formats(n, 1);
  for (int i = 0; i < n; ++i) {
    values[i] = params.null_[i] ? nullptr : params.values_[i].data();
    lengths[i] = static_cast<int>(params.values_[i].size());
  }
  Result result(PQexecPrepared(conn_, it->second.c_str(), n, values.data(), lengths.data(),
                               formats.data(), /*resultFormat=*/1));
  const ExecStatusType status = PQresultStatus(result.result_.get());
  if (status != PGRES_COMMAND_OK && status != PGRES_TUPLES_OK) {
    return Error(result.result_.get(), conn_, Describe(sql), on_unique);
  }
  return result;
}

absl::Status Connection::Script(absl::string_view sql) {
  const std::string text(sql);
  Result result(PQexec(conn_, text.c_str()));
  const ExecStatusType status = PQresultStatus(result.result_.get());
  if (status != PGRES_COMMAND_OK && status != PGRES_TUPLES_OK) {
    return Error(result.result_.get(), conn_, Describe(sql));
  }
  return absl::OkStatus();
}

absl::StatusOr<std::unique_ptr<Pool>> Pool::Open(const std::string& uri, Options options) {
  if (options.size < 1) return absl::InvalidArgumentError("a connection pool needs 1 connection");
  std::unique_ptr<Pool> pool(new Pool(uri, options));
  // One connection now, so a wrong address or password is reported at start-up.
  absl::StatusOr<std::unique_ptr<Connection>> first = pool->Acquire();
  if (!first.ok()) return first.status();
  pool->Release(*std::move(first));
  return pool;
}

absl::StatusOr<std::unique_ptr<Connection>> Pool::Acquire() {
  std::unique_ptr<Connection> connection;
  {
    std::unique_lock<std::mutex> lock(mutex_);
    const auto deadline = std::chrono::steady_clock::now() + options_.acquire_timeout;
    while (idle_.empty() && open_ >= options_.size) {
      if (available_.wait_until(lock, deadline) == std::cv_status::timeout && idle_.empty() &&
          open_ >= options_.size) {
        return absl::UnavailableError(absl::StrCat("all ", options_.size,
                                                   " connections to PostgreSQL stayed busy for ",
                                                   options_.acquire_timeout.count(), " ms"));
      }
    }
    if (!idle_.empty()) {
      connection = std::move(idle_.back());
      idle_.pop_back();
    } else {
      ++open_;
    }
  }
  if (connection == nullptr) {
    absl::StatusOr<std::unique_ptr<Connection>> opened = Connection::Open(uri_);
    if (!opened.ok()) {
      std::lock_guard<std::mutex> lock(mutex_);
      --open_;
      available_.notify_one();
      return opened.status();
    }
    return opened;
  }
  if (!connection->healthy()) {
    if (absl::Status reset = connection->Reset(); !reset.ok()) {
      Release(std::move(connection));  // kept: the next caller tries to reconnect it again
      return reset;
    }
  }
  return connection;
}

absl::StatusOr<Pool::Lease> Pool::Hold() {
  absl::StatusOr<std::unique_ptr<Connection>> connection = Acquire();
  if (!connection.ok()) return connection.status();
  return Lease(this, *std::move(connection));
}

void Pool::Release(std::unique_ptr<Connection> connection) {
  std::lock_guard<std::mutex> lock(mutex_);
  idle_.push_back(std::move(connection));
  available_.notify_one();
}

absl::Status Pool::Run(const std::function<absl::Status(Connection&)>& body) {
  absl::StatusOr<std::unique_ptr<Connection>> connection = Acquire();
  if (!connection.ok()) return connection.status();
  absl::Status status = body(**connection);
  Release(*std::move(connection));
  return status;
}

absl::Status Pool::Transaction(const std::function<absl::Status(Connection&)>& body) {
  for (int attempt = 0;; ++attempt) {
    absl::StatusOr<std::unique_ptr<Connection>> acquired = Acquire();
    if (!acquired.ok()) return acquired.status();
    Connection& connection = **acquired;
    absl::Status status = connection.Script("BEGIN");
    if (status.ok()) status = body(connection);
    if (status.ok()) status = connection.Script("COMMIT");
    if (!status.ok() && connection.healthy()) connection.Script("ROLLBACK").IgnoreError();
    Release(*std::move(acquired));
    if (status.ok() || !absl::IsAborted(status) || attempt >= options_.max_retries) return status;
    // Another transaction won the race; let it finish before trying again.
    std::this_thread::sleep_for(std::chrono::milliseconds(5 * (attempt + 1)));
  }
}

}  // namespace waymark::storage::pg
