#include "client/bags/db3_file.h"

#include <sqlite3.h>

#include <cstring>
#include <filesystem>
#include <map>
#include <set>

#include "absl/strings/str_cat.h"
#include "absl/strings/str_join.h"
#include "client/bags/chunked_reader.h"
#include "client/bags/decompress.h"

namespace waymark::bags {
namespace {

constexpr unsigned char kZstdMagic[] = {0x28, 0xb5, 0x2f, 0xfd};

struct DbCloser {
  void operator()(sqlite3* db) const { sqlite3_close_v2(db); }
};
struct StatementCloser {
  void operator()(sqlite3_stmt* statement) const { sqlite3_finalize(statement); }
};
using Statement = std::unique_ptr<sqlite3_stmt, StatementCloser>;

std::string Text(sqlite3_stmt* statement, int column) {
  const unsigned char* text = sqlite3_column_text(statement, column);
  return text == nullptr ? std::string() : std::string(reinterpret_cast<const char*>(text));
}

// A path as an sqlite URI's path: the characters URIs give a meaning to are escaped.
std::string UriPath(const std::string& path) {
  std::string out;
  for (const char c : path) {
    if (c == '%' || c == '?' || c == '#') {
      absl::StrAppend(&out, "%", absl::Hex(static_cast<unsigned char>(c), absl::kZeroPad2));
    } else {
      out += c;
    }
  }
  return out;
}

class Db3File final : public BagReader {
 public:
  Db3File(std::string path, Db3Options options) : path_(std::move(path)), options_(options) {}

  absl::Status Open();
  const std::vector<BagConnection>& connections() const override { return connections_; }
  absl::StatusOr<BagSummary> Summary() override;
  absl::StatusOr<bool> Next(BagMessage* message) override;
  void Select(const std::vector<int>& wanted) override;
  const std::vector<std::string>& warnings() const override { return warnings_; }

 private:
  absl::Status OpenDatabase(const std::string& uri);
  absl::StatusOr<Statement> Prepare(const std::string& sql) const;
  absl::Status Error(const std::string& what) const {
    return absl::DataLossError(absl::StrCat(path_, ": ", what, ": ", sqlite3_errmsg(db_.get())));
  }
  bool HasTable(const std::string& name) const;
  std::set<std::string> Columns(const std::string& table) const;
  absl::Status PrepareMessages();

  std::string path_;
  Db3Options options_;
  std::unique_ptr<sqlite3, DbCloser> db_;
  std::vector<BagConnection> connections_;
  std::vector<std::string> warnings_;
  std::vector<int> wanted_;
  Statement messages_;
  bool started_ = false;
  bool done_ = false;
  int64_t last_timestamp_ = 0;
  int64_t last_row_ = 0;
};

absl::StatusOr<Statement> Db3File::Prepare(const std::string& sql) const {
  sqlite3_stmt* raw = nullptr;
  if (sqlite3_prepare_v2(db_.get(), sql.c_str(), -1, &raw, nullptr) != SQLITE_OK) {
    sqlite3_finalize(raw);
    return Error(absl::StrCat("query failed (", sql, ")"));
  }
  return Statement(raw);
}

bool Db3File::HasTable(const std::string& name) const {
  absl::StatusOr<Statement> statement =
      Prepare("SELECT 1 FROM sqlite_master WHERE type = 'table' AND name = ?");
  if (!statement.ok()) return false;
  sqlite3_bind_text(statement->get(), 1, name.c_str(), -1, SQLITE_TRANSIENT);
  return sqlite3_step(statement->get()) == SQLITE_ROW;
}

std::set<std::string> Db3File::Columns(const std::string& table) const {
  std::set<std::string> columns;
  absl::StatusOr<Statement> statement = Prepare(absl::StrCat("PRAGMA table_info(", table, ")"));
  if (!statement.ok()) return columns;
  while (sqlite3_step(statement->get()) == SQLITE_ROW) columns.insert(Text(statement->get(), 1));
  return columns;
}

absl::Status Db3File::OpenDatabase(const std::string& uri) {
  sqlite3* raw = nullptr;
  const int code = sqlite3_open_v2(uri.c_str(), &raw, SQLITE_OPEN_READONLY | SQLITE_OPEN_URI, nullptr);
  db_.reset(raw);
  if (code != SQLITE_OK) return Error("cannot open");
  // Opening is lazy: the first read says whether the file is a database (and its WAL readable).
  absl::StatusOr<Statement> probe = Prepare("SELECT count(*) FROM sqlite_master");
  if (!probe.ok()) return probe.status();
  if (sqlite3_step(probe->get()) != SQLITE_ROW) return Error("not a readable sqlite3 database");
  return absl::OkStatus();
}

absl::Status Db3File::Open() {
  // Read-only first (a finished bag's WAL, if any, is applied); a bag in a read-only folder whose
  // -shm cannot be opened is read as immutable instead (its WAL, if it holds anything, is then
  // not seen: said as a warning).
  absl::Status opened = OpenDatabase(absl::StrCat("file:", UriPath(path_), "?mode=ro"));
  if (!opened.ok()) {
    opened = OpenDatabase(absl::StrCat("file:", UriPath(path_), "?immutable=1"));
    if (!opened.ok()) return opened;
    std::error_code error;
    if (std::filesystem::file_size(path_ + "-wal", error) > 0 && !error) {
      warnings_.push_back(absl::StrCat(path_, ": its write-ahead log could not be opened read-only; "
                                              "messages still in it are not read"));
    }
  }
  if (!HasTable("topics") || !HasTable("messages")) {
    return absl::InvalidArgumentError(
        absl::StrCat(path_, ": an sqlite3 database without rosbag2's topics and messages tables"));
  }
  const std::set<std::string> topic_columns = Columns("topics");
  const bool has_format = topic_columns.count("serialization_format") > 0;
  std::map<std::string, std::pair<std::string, std::string>> definitions;  // type -> (encoding, text)
  if (HasTable("message_definitions")) {
    absl::StatusOr<Statement> statement =
        Prepare("SELECT topic_type, encoding, encoded_message_definition FROM message_definitions");
    if (!statement.ok()) return statement.status();
    while (sqlite3_step(statement->get()) == SQLITE_ROW) {
      definitions[Text(statement->get(), 0)] = {Text(statement->get(), 1), Text(statement->get(), 2)};
    }
  }
  absl::StatusOr<Statement> topics = Prepare(absl::StrCat(
      "SELECT id, name, type, ", has_format ? "serialization_format" : "'cdr'", " FROM topics ORDER BY id"));
  if (!topics.ok()) return topics.status();
  while (sqlite3_step(topics->get()) == SQLITE_ROW) {
    BagConnection connection;
    connection.id = sqlite3_column_int(topics->get(), 0);
    connection.topic = Text(topics->get(), 1);
    connection.raw_type = Text(topics->get(), 2);
    connection.type = NormalizeType(connection.raw_type);
    connection.encoding_name = Text(topics->get(), 3);
    if (connection.encoding_name == "cdr") connection.encoding = MessageEncoding::kCdr;
    if (connection.encoding_name == "ros1") connection.encoding = MessageEncoding::kRos1;
    auto definition = definitions.find(connection.raw_type);
    if (definition != definitions.end()) connection.definition = definition->second.second;
    connections_.push_back(std::move(connection));
  }
  return absl::OkStatus();
}

void Db3File::Select(const std::vector<int>& wanted) {
  wanted_ = wanted;
  messages_.reset();  // prepared again from where reading stopped
}

absl::Status Db3File::PrepareMessages() {
  std::string where;
  if (started_) where = "WHERE (timestamp, id) > (?1, ?2)";
  if (!wanted_.empty()) {
    absl::StrAppend(&where, where.empty() ? "WHERE " : " AND ", "topic_id IN (",
                    absl::StrJoin(wanted_, ","), ")");
  }
  absl::StatusOr<Statement> statement = Prepare(absl::StrCat(
      "SELECT topic_id, timestamp, id, data FROM messages ", where, " ORDER BY timestamp, id"));
  if (!statement.ok()) return statement.status();
  if (started_) {
    sqlite3_bind_int64(statement->get(), 1, last_timestamp_);
    sqlite3_bind_int64(statement->get(), 2, last_row_);
  }
  messages_ = *std::move(statement);
  return absl::OkStatus();
}

absl::StatusOr<bool> Db3File::Next(BagMessage* message) {
  if (done_) return false;
  if (!messages_) {
    if (absl::Status status = PrepareMessages(); !status.ok()) return status;
  }
  const int code = sqlite3_step(messages_.get());
  if (code == SQLITE_DONE) {
    done_ = true;
    return false;
  }
  if (code != SQLITE_ROW) {
    // A damaged page ends the stream with what was read, as a cut ROS 1 bag does.
    warnings_.push_back(absl::StrCat(path_, ": reading stopped early: ", sqlite3_errmsg(db_.get())));
    done_ = true;
    return false;
  }
  started_ = true;
  message->connection_id = sqlite3_column_int(messages_.get(), 0);
  last_timestamp_ = sqlite3_column_int64(messages_.get(), 1);
  last_row_ = sqlite3_column_int64(messages_.get(), 2);
  message->log_time_ns = last_timestamp_;
  const void* blob = sqlite3_column_blob(messages_.get(), 3);
  const int size = sqlite3_column_bytes(messages_.get(), 3);
  std::string_view data(static_cast<const char*>(blob), blob == nullptr ? 0 : size);
  const bool zstd = options_.zstd_messages ||
                    (options_.detect_zstd && data.size() >= 4 &&
                     std::memcmp(data.data(), kZstdMagic, 4) == 0);
  if (!zstd) {
    message->data.assign(data);
    return true;
  }
  absl::StatusOr<std::string> expanded = DecompressZstdUpTo(data, kMaxExpandedBytes);
  if (!expanded.ok()) {
    return absl::DataLossError(absl::StrCat(path_, ": message ", last_row_,
                                            " does not expand as zstd: ", expanded.status().message()));
  }
  message->data = *std::move(expanded);
  return true;
}

absl::StatusOr<BagSummary> Db3File::Summary() {
  BagSummary summary;
  summary.format = "rosbag2 sqlite3";
  summary.compression = options_.zstd_messages ? "zstd (per message)" : "none";
  if (!options_.zstd_messages && options_.detect_zstd) {
    absl::StatusOr<Statement> first = Prepare("SELECT data FROM messages LIMIT 1");
    if (first.ok() && sqlite3_step(first->get()) == SQLITE_ROW &&
        sqlite3_column_bytes(first->get(), 0) >= 4 &&
        std::memcmp(sqlite3_column_blob(first->get(), 0), kZstdMagic, 4) == 0) {
      summary.compression = "zstd (per message, found without metadata.yaml)";
    }
  }
  summary.files = {path_};
  absl::StatusOr<Statement> statement = Prepare(
      "SELECT topic_id, COUNT(*), MIN(timestamp), MAX(timestamp) FROM messages GROUP BY topic_id");
  if (!statement.ok()) return statement.status();
  std::map<int, int64_t> counts;
  while (sqlite3_step(statement->get()) == SQLITE_ROW) {
    const int64_t count = sqlite3_column_int64(statement->get(), 1);
    const int64_t start = sqlite3_column_int64(statement->get(), 2);
    const int64_t end = sqlite3_column_int64(statement->get(), 3);
    if (summary.messages == 0 || start < summary.start_ns) summary.start_ns = start;
    if (summary.messages == 0 || end > summary.end_ns) summary.end_ns = end;
    counts[sqlite3_column_int(statement->get(), 0)] += count;
    summary.messages += count;
  }
  std::map<std::string, BagTopicSummary> rows;
  for (const BagConnection& connection : connections_) {
    BagTopicSummary& row = rows[connection.topic];
    row.topic = connection.topic;
    row.type = connection.type;
    row.messages += counts[connection.id];
  }
  for (auto& [topic, row] : rows) summary.topics.push_back(std::move(row));
  return summary;
}

}  // namespace

absl::StatusOr<std::unique_ptr<BagReader>> OpenDb3File(const std::string& path, Db3Options options) {
  auto file = std::make_unique<Db3File>(path, options);
  if (absl::Status status = file->Open(); !status.ok()) return status;
  return std::unique_ptr<BagReader>(std::move(file));
}

}  // namespace waymark::bags
